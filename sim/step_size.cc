#include "sim/step_size.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tribo::sim {

LateralRates lateral_rate_bounds(const LateralAxisParams& axis, const LugreParams& friction,
                                 const FrictionLevels& levels, const LateralState& s,
                                 double drive_n, double dt_s) {
  const double m = axis.mass_kg;
  const double oscillation =
      std::sqrt((axis.spring_n_per_m + (levels.in_contact() ? friction.sigma0_n_per_m : 0)) / m);
  if (!levels.in_contact()) {
    const double rate = axis.damping_n_s_per_m / m + oscillation;
    return LateralRates{rate, rate};
  }
  const double f_min = std::min(levels.static_n, levels.coulomb_n);
  const double f_max = std::max(levels.static_n, levels.coulomb_n);
  const double g_min = f_min / friction.sigma0_n_per_m;
  const double shape = 1.0 + (f_max - f_min) / (std::numbers::e * f_min);
  const auto damping = [&](double z_ratio) {
    const double dzdot_dv = 1.0 + z_ratio * shape;
    return (axis.damping_n_s_per_m + friction.sigma2_n_s_per_m + friction.sigma1_n_s_per_m * dzdot_dv) / m;
  };
  const double accel = std::fabs(lateral_derivative(axis, friction, levels, s, drive_n).dv);
  const double v_reach = std::fabs(s.velocity_m_per_s) + accel * dt_s;
  const double z_ratio = std::fabs(s.bristle_m) / g_min;
  return LateralRates{damping(z_ratio) + v_reach / g_min + oscillation,
                      damping(f_max / f_min) + oscillation};
}

namespace {

// Sub-steps for h * rate <= max_h_lambda; a NaN rate compares false and asks for "too many".
double wanted_substeps(double rate, double dt_s, double max_h_lambda) {
  const double n = std::ceil(rate * dt_s / max_h_lambda);
  return std::isnan(n) ? HUGE_VAL : std::max(1.0, n);
}

}  // namespace

StepPlan plan_substeps(const LateralRates& rates, double dt_s, double max_h_lambda,
                       int max_substeps) {
  const double full = wanted_substeps(rates.full_per_s, dt_s, max_h_lambda);
  if (full <= max_substeps) return StepPlan{static_cast<int>(full), false, false};
  const double split = wanted_substeps(rates.split_per_s, dt_s, max_h_lambda);
  if (split <= max_substeps) return StepPlan{static_cast<int>(split), true, false};
  return StepPlan{max_substeps, true, true};
}

}  // namespace tribo::sim
