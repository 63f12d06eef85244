#include "sim/normal_axis.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

double hertz_coefficient(const NormalAxisParams& p) {
  return 4.0 / 3.0 * p.reduced_modulus_pa * std::sqrt(p.tip_radius_m);
}

double normal_actuator_force_n(const NormalAxisParams& p, double command_n, double measured_m,
                               double true_m) {
  if (p.plate_area_m2 <= 0) return command_n;
  const double pressing = command_n >= 0 ? 1.0 : -1.0;  // which plate pulls
  const double ratio = (p.calibrated_gap_m - pressing * measured_m) / (p.gap_m - pressing * true_m);
  return command_n * p.plate_area_m2 / p.calibrated_area_m2 * ratio * ratio;
}

NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double force_n,
                                           double surface_height_m, double depth_guess_m) {
  return solve_normal_equilibrium(p, hertz_coefficient(p), force_n, surface_height_m, depth_guess_m);
}

NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double stiff, double force_n,
                                           double surface_height_m, double depth_guess_m) {
  const double k = p.spring_n_per_m;
  // With d = z + h the Hertz approach: F + k h = k d + K d^(3/2).
  const double pressing = force_n + k * surface_height_m;
  if (pressing <= 0) return NormalEquilibrium{force_n / k, 0.0, 0.0};
  // With u = sqrt(d): f(u) = K u^3 + k u^2 - F', convex and increasing for
  // u > 0. Halley's method (u -= f f' / (f'^2 - f f''/2)) from above the root
  // descends monotonically onto it, cubically: after a step of relative size
  // 1e-4 the error is of order 1e-12 u (3e-12 of the load: 3e-14 N at
  // 10 mN, far below the normal force's 0.1 uN noise), so that step is the
  // last. From the previous tick's depth the first step is usually that
  // small. sqrt(F'/k) and cbrt(F'/K) both lie above the root.
  double u = depth_guess_m > 0 ? std::sqrt(depth_guess_m)
                               : std::min(std::sqrt(pressing / k), std::cbrt(pressing / stiff));
  for (int i = 0; i < 60; ++i) {
    const double f = (stiff * u + k) * u * u - pressing;
    const double slope = (3.0 * stiff * u + 2.0 * k) * u;
    const double curvature = 6.0 * stiff * u + 2.0 * k;
    const double step = f * slope / (slope * slope - 0.5 * f * curvature);
    u -= step;
    if (!(std::fabs(step) > 1e-4 * u)) break;
  }
  const double d = u * u;
  return NormalEquilibrium{d - surface_height_m, stiff * d * u, d};
}

double reported_normal_force_n(const NormalAxisParams& p, double command_n, double measured_m) {
  return command_n - p.calibrated_spring_n_per_m * measured_m;
}

double hertz_depth_m(const NormalAxisParams& p, double load_n) {
  if (load_n <= 0) return 0.0;
  return std::cbrt(std::pow(load_n / hertz_coefficient(p), 2.0));
}

double hertz_contact_radius_m(const NormalAxisParams& p, double load_n) {
  return std::sqrt(p.tip_radius_m * hertz_depth_m(p, load_n));
}

double spherical_cap_depth_m(const NormalAxisParams& p) {
  const double c = std::cos(p.cone_half_angle_rad);
  return p.tip_radius_m * c * c;
}

}  // namespace tribo::sim
