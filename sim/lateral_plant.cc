#include "sim/lateral_plant.h"

#include <cmath>
#include <utility>

namespace tribo::sim {

LateralDerivative lateral_derivative(const LateralAxisParams& axis, const LugreParams& friction,
                                     const FrictionLevels& levels, const LateralState& s,
                                     double drive_n) {
  const LugreOutput f = lugre_evaluate(friction, levels, s.velocity_m_per_s, s.bristle_m);
  const double spring_damper =
      axis.spring_n_per_m * s.position_m + axis.damping_n_s_per_m * s.velocity_m_per_s;
  return LateralDerivative{s.velocity_m_per_s, (drive_n - spring_damper - f.force_n) / axis.mass_kg,
                           f.dz_dt_m_per_s, f.force_n};
}

namespace {

LateralState advanced(const LateralState& s, const LateralDerivative& d, double h) {
  return LateralState{s.position_m + h * d.dx, s.velocity_m_per_s + h * d.dv,
                      s.bristle_m + h * d.dz};
}

}  // namespace

void integrate_lateral(const LateralAxisParams& axis, const LugreParams& friction,
                       const FrictionLevels& levels, double drive_n, double dt_s, int substeps,
                       LateralState& s) {
  const double h = dt_s / substeps;
  for (int i = 0; i < substeps; ++i) {
    const auto k1 = lateral_derivative(axis, friction, levels, s, drive_n);
    const auto k2 = lateral_derivative(axis, friction, levels, advanced(s, k1, h / 2), drive_n);
    const auto k3 = lateral_derivative(axis, friction, levels, advanced(s, k2, h / 2), drive_n);
    const auto k4 = lateral_derivative(axis, friction, levels, advanced(s, k3, h), drive_n);
    s.position_m += h / 6 * (k1.dx + 2 * k2.dx + 2 * k3.dx + k4.dx);
    s.velocity_m_per_s += h / 6 * (k1.dv + 2 * k2.dv + 2 * k3.dv + k4.dv);
    s.bristle_m += h / 6 * (k1.dz + 2 * k2.dz + 2 * k3.dz + k4.dz);
  }
}

namespace {

// Solution of dz/dt = v - alpha a z over h for frozen v and alpha (a = |v|/g):
// exact for plain LuGre. With elasto-plastic presliding alpha rises to 1 as
// |z| reaches g, so a bristle loading towards g stops there instead of at the
// frozen-alpha target g/alpha.
double relax_bristle(const LugreParams& friction, const FrictionLevels& levels, double v, double z,
                     double h) {
  if (!levels.in_contact() || v == 0.0) return z;
  const double g = stribeck_n(friction, levels, v) / friction.sigma0_n_per_m;
  const double alpha = plasticity(friction, v, z, g);
  const double rate = alpha * std::fabs(v) / g;
  double next = rate > 0 ? v / rate + (z - v / rate) * std::exp(-rate * h) : z + v * h;
  const double limit = v > 0 ? g : -g;
  const bool was_inside = std::fabs(z) <= g;
  if (was_inside && (v > 0 ? next > limit : next < limit)) next = limit;
  return next;
}

}  // namespace

void integrate_lateral_split(const LateralAxisParams& axis, const LugreParams& friction,
                             const FrictionLevels& levels, double drive_n, double dt_s,
                             int substeps, LateralState& s) {
  const double h = dt_s / substeps;
  for (int i = 0; i < substeps; ++i) {
    s.bristle_m = relax_bristle(friction, levels, s.velocity_m_per_s, s.bristle_m, h / 2);
    // RK4 on (x, v) with z frozen; the friction force keeps its sigma1 dz/dt term.
    const auto frozen = [&](double x, double v) {
      auto d = lateral_derivative(axis, friction, levels, LateralState{x, v, s.bristle_m}, drive_n);
      return std::pair{d.dx, d.dv};
    };
    const double x = s.position_m, v = s.velocity_m_per_s;
    const auto [x1, v1] = frozen(x, v);
    const auto [x2, v2] = frozen(x + h / 2 * x1, v + h / 2 * v1);
    const auto [x3, v3] = frozen(x + h / 2 * x2, v + h / 2 * v2);
    const auto [x4, v4] = frozen(x + h * x3, v + h * v3);
    s.position_m += h / 6 * (x1 + 2 * x2 + 2 * x3 + x4);
    s.velocity_m_per_s += h / 6 * (v1 + 2 * v2 + 2 * v3 + v4);
    s.bristle_m = relax_bristle(friction, levels, s.velocity_m_per_s, s.bristle_m, h / 2);
  }
}

}  // namespace tribo::sim
