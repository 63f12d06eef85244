#include "sim/lugre_friction.h"

#include <cmath>
#include <numbers>

#include "sim/quarter_sine.h"

namespace tribo::sim {

FrictionLevels friction_levels(const LugreParams& p, double contact_load_n) {
  const double load = contact_load_n > 0 ? contact_load_n : 0.0;
  return FrictionLevels{p.static_coeff * load, p.coulomb_coeff * load, 0.0};
}

double stribeck_shape(const LugreParams& p, double v) {
  const double ratio = std::fabs(v) / p.stribeck_velocity_m_per_s;
  if (p.stribeck_exponent == 1.0) return std::exp(-ratio);
  if (p.stribeck_exponent == 2.0) return std::exp(-ratio * ratio);
  return std::exp(-std::pow(ratio, p.stribeck_exponent));
}

double stribeck_n(const LugreParams& p, const FrictionLevels& levels, double v) {
  return levels.coulomb_n + (levels.static_n - levels.coulomb_n) * stribeck_shape(p, v);
}

double steady_state_friction_n(const LugreParams& p, double contact_load_n, double v) {
  const FrictionLevels levels = friction_levels(p, contact_load_n);
  if (!levels.in_contact()) return 0.0;
  const double sign = v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
  return sign * stribeck_n(p, levels, v) + p.sigma2_n_s_per_m * v;
}

namespace {

// alpha of the blend at u = z / g (r > 0). The divisions by parameters are
// taken off the evaluation's dependency chain (multiplications by their
// reciprocals), and the sine is sine_on_quarter's (for speed).
double blend(double r, double v, double u) {
  if ((u > 0) != (v > 0) || u == 0) return 0.0;
  const double uabs = std::fabs(u);
  if (uabs <= r) return 0.0;
  if (uabs >= 1.0) return 1.0;
  return 0.5 + 0.5 * sine_on_quarter((uabs - 0.5 * (1 + r)) * (std::numbers::pi / (1 - r)));
}

}  // namespace

double plasticity(double r, double v, double z, double g) {
  if (r <= 0) return 1.0;
  return blend(r, v, z / g);
}

LugreOutput lugre_bristle_at_inverse_scale(const LugreParams& p, double inverse_g, double v, double z) {
  const double u = z * inverse_g;  // shared by alpha and the slip rate
  const double alpha = p.breakaway_ratio <= 0 ? 1.0 : blend(p.breakaway_ratio, v, u);
  const double dz = v - alpha * std::fabs(v) * u;
  return LugreOutput{dz, p.sigma0_n_per_m * z + p.sigma1_n_s_per_m * dz + p.sigma2_n_s_per_m * v, alpha};
}

LugreOutput lugre_bristle(const LugreParams& p, double g, double v, double z) {
  return lugre_bristle_at_inverse_scale(p, 1.0 / g, v, z);
}

LugreOutput lugre_evaluate(const LugreParams& p, const FrictionLevels& levels, double v, double z) {
  if (!levels.in_contact()) return {};
  return lugre_bristle(p, stribeck_n(p, levels, v) / p.sigma0_n_per_m, v, z);
}

}  // namespace tribo::sim
