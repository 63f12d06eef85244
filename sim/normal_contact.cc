#include "sim/normal_contact.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

namespace {

double hertz_coefficient(const NormalAxisParams& p) {
  return 4.0 / 3.0 * p.reduced_modulus_pa * std::sqrt(p.tip_radius_m);
}

}  // namespace

NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double force_n) {
  if (force_n <= 0) return NormalEquilibrium{force_n / p.spring_n_per_m, 0.0};
  // With u = sqrt(d): f(u) = K u^3 + k u^2 - F, convex and increasing for u > 0.
  // Both sqrt(F/k) and cbrt(F/K) lie above the root, so Newton from the smaller
  // one descends monotonically onto it.
  const double k = p.spring_n_per_m;
  const double stiff = hertz_coefficient(p);
  double u = std::min(std::sqrt(force_n / k), std::cbrt(force_n / stiff));
  for (int i = 0; i < 60; ++i) {
    const double f = (stiff * u + k) * u * u - force_n;
    const double step = f / (3.0 * stiff * u * u + 2.0 * k * u);
    u -= step;
    if (!(step > 1e-15 * u)) break;
  }
  const double d = u * u;
  return NormalEquilibrium{d, stiff * d * u};
}

double hertz_depth_m(const NormalAxisParams& p, double load_n) {
  if (load_n <= 0) return 0.0;
  return std::cbrt(std::pow(load_n / hertz_coefficient(p), 2.0));
}

double hertz_contact_radius_m(const NormalAxisParams& p, double load_n) {
  return std::sqrt(p.tip_radius_m * hertz_depth_m(p, load_n));
}

}  // namespace tribo::sim
