#include "sim/friction_effects.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/log_near_one.h"

namespace tribo::sim {

double effective_load_n(const LoadDependenceParams& p, double n) {
  const double load = n > 0 ? n : 0.0;
  if (!p.enabled) return load;
  return p.reference_load_n * std::pow((load + p.adhesion_load_n) / p.reference_load_n, p.exponent);
}

double orientation_factor(const OrientationAnisotropyParams& p, double rotation_deg) {
  if (!p.enabled) return 1.0;
  return 1.0 + p.amplitude * std::cos(2 * std::numbers::pi * (rotation_deg - p.max_at_deg) / p.period_deg);
}

FrictionLevels contact_levels(const FrictionModel& m, double n, double rotation_deg,
                              double local_factor) {
  if (!(n > 0)) return {};
  const double scale = effective_load_n(m.load_dependence, n) *
                       orientation_factor(m.orientation_anisotropy, rotation_deg) * local_factor;
  const double strengthening =
      m.velocity_strengthening.enabled ? m.velocity_strengthening.coeff * scale : 0.0;
  return FrictionLevels{m.lugre.static_coeff * scale, m.lugre.coulomb_coeff * scale, strengthening,
                        m.rate_state.enabled ? scale : 0.0};
}

double rate_state_n(const FrictionModel& m, const FrictionLevels& levels, double v, double phi) {
  if (levels.rate_state_n <= 0) return 0.0;
  const RateStateParams& r = m.rate_state;
  return levels.rate_state_n * (r.direct_coeff * std::log1p(std::fabs(v) * (1.0 / r.reference_velocity_m_per_s)) +
                                r.state_coeff * std::log(std::max(phi * (r.reference_velocity_m_per_s / r.memory_length_m),
                                                                  kMinRateStateRatio)));
}

double rate_state_rate(const RateStateParams& p, double v, double phi) {
  const double x = (std::fabs(v) + p.reference_velocity_m_per_s) * (phi * (1.0 / p.memory_length_m));
  if (p.law == StateLaw::kAgeing) return 1.0 - x;
  return x > 0 ? -x * std::log(x) : 0.0;
}

double relax_rate_state(const RateStateParams& p, double v, double phi, double h) {
  const double rate = (std::fabs(v) + p.reference_velocity_m_per_s) / p.memory_length_m;
  if (p.law == StateLaw::kAgeing) return 1 / rate + (phi - 1 / rate) * std::exp(-rate * h);
  if (phi <= 0) return phi;
  // u = ln(rate phi) obeys du/dt = -rate u.
  return std::exp(std::log(rate * phi) * std::exp(-rate * h)) / rate;
}

namespace {

// The terms of S that depend on the contact point but not on the Stribeck
// speed: evaluated once when S is wanted both sliding and at rest.
struct PointTerms {
  double fs = 0;             // Fs D
  double state_log = 0;      // ln(max(V* phi / D_c, ...)) of the rate-and-state law
  double periodic = 1;       // M_p
};

PointTerms point_terms(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c) {
  PointTerms t;
  t.fs = levels.static_n;
  if (m.dwell_stiction.enabled) {
    const double age = c.contact_age_s;
    t.fs *= 1.0 + m.dwell_stiction.gain * age / (age + m.dwell_stiction.time_constant_s);
  }
  if (levels.rate_state_n > 0) {
    const RateStateParams& r = m.rate_state;
    t.state_log = std::log(std::max(c.rate_state_s * (r.reference_velocity_m_per_s / r.memory_length_m), kMinRateStateRatio));
  }
  if (m.position_periodic.enabled) {
    const auto& p = m.position_periodic;
    t.periodic = 1.0 + p.amplitude * std::sin(2 * std::numbers::pi * c.sample_position_m / p.period_m + p.phase_rad);
  }
  return t;
}

// The terms of S that depend on the Stribeck speed vs: the shape and the
// logarithms of the strengthening and the rate-and-state direct effect.
struct SpeedTerms {
  double shape = 1;
  double strengthening_log = 0;
  double direct_log = 0;
};

SpeedTerms speed_terms(const FrictionModel& m, const FrictionLevels& levels, const PointTerms& point, double vs,
                       double direct_v) {
  SpeedTerms t;
  // Where Fs D = Fc the shape multiplies 0: S is the same without its exp.
  if (point.fs != levels.coulomb_n) t.shape = stribeck_shape(m.lugre, vs);
  if (levels.strengthening_n > 0) {
    t.strengthening_log = std::log1p(std::fabs(vs) / m.velocity_strengthening.reference_velocity_m_per_s);
  }
  if (levels.rate_state_n > 0 && direct_v != 0.0) {  // log1p(0) = 0
    t.direct_log = std::log1p(std::fabs(direct_v) * (1.0 / m.rate_state.reference_velocity_m_per_s));
  }
  return t;
}

// At rest (vs = 0) the shape is exp(-0) = 1 and both logarithms log1p(0) = 0
// exactly: the default SpeedTerms, without calling exp and log1p.
constexpr SpeedTerms kAtRest{};

// S from the point's and the speed's terms, the direction asymmetry taken
// for sgn(direction): the operations of rate_state_n and of the effects in
// the order of the header's equation.
double stribeck_at(const FrictionModel& m, const FrictionLevels& levels, const PointTerms& t,
                   const SpeedTerms& speed, double direction) {
  double s = levels.coulomb_n + (t.fs - levels.coulomb_n) * speed.shape;
  if (levels.strengthening_n > 0) s += levels.strengthening_n * speed.strengthening_log;
  if (levels.rate_state_n > 0) {
    const RateStateParams& r = m.rate_state;
    const double added = levels.rate_state_n * (r.direct_coeff * speed.direct_log + r.state_coeff * t.state_log);
    s = std::max(s + added, kRateStateFloor * levels.coulomb_n);
  }
  if (m.position_periodic.enabled) s *= t.periodic;
  if (m.direction_asymmetry.enabled && direction != 0.0) {
    s *= 1.0 + (direction > 0 ? m.direction_asymmetry.ratio : -m.direction_asymmetry.ratio);
  }
  return s;
}

// The velocity the direct effect takes at the point.
double direct_velocity(const FrictionModel& m, const ContactPoint& c) {
  return m.rate_state.direct_rate == DirectEffectRate::kSlipRate ? c.slip_rate_m_per_s : c.stribeck_velocity_m_per_s;
}

}  // namespace

double stribeck_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c) {
  const PointTerms t = point_terms(m, levels, c);
  return stribeck_at(m, levels, t, speed_terms(m, levels, t, c.stribeck_velocity_m_per_s, direct_velocity(m, c)),
                     c.velocity_m_per_s);
}

namespace {

// d alpha / d|u| and d^2 alpha / d|u|^2 of the elasto-plastic blend where
// alpha is its value: alpha = (1 + sin theta) / 2, theta = pi (|u| - (1 + r)/2)
// / (1 - r) in [-pi/2, pi/2], so cos theta = 2 sqrt(alpha (1 - alpha)) and
// sin theta = 2 alpha - 1: both without a trigonometric function; 0 outside
// the blend (alpha 0 or 1).
struct BlendSlopes {
  double first = 0, second = 0;
};

BlendSlopes blend_slopes(double breakaway_ratio, double alpha) {
  if (breakaway_ratio <= 0 || !(alpha > 0 && alpha < 1)) return {};
  const double k = std::numbers::pi / (1 - breakaway_ratio);
  return BlendSlopes{k * std::sqrt(alpha * (1 - alpha)), -k * k * (alpha - 0.5)};
}

// stribeck_n_at_deflection with the point's terms given, the direct effect
// on the slip rate.
double solve_at_deflection(const FrictionModel& m, const FrictionLevels& levels, const PointTerms& t, ContactPoint& c,
                           double z, double guess_n) {
  SpeedTerms speed = speed_terms(m, levels, t, c.stribeck_velocity_m_per_s, 0.0);
  const double v = c.velocity_m_per_s, sigma0 = m.lugre.sigma0_n_per_m, r = m.lugre.breakaway_ratio;
  const double v_star = m.rate_state.reference_velocity_m_per_s, inverse_v_star = 1.0 / v_star;
  // S is affine in L = ln(1 + |v_s| / V*) above the floor: S(L) = S(0) + K L.
  auto s_of = [&](double log_term) {
    speed.direct_log = log_term;
    return stribeck_at(m, levels, t, speed, v);
  };
  const double s0 = s_of(0.0);
  const double u0 = z * sigma0 / s0;
  if (plasticity(r, v, u0, 1.0) * std::fabs(v) * u0 == 0.0) {  // stuck (alpha = 0) or at rest: no slip whatever S
    c.slip_rate_m_per_s = 0.0;
    return s0;
  }
  const double slope = s_of(1.0) - s0;
  const double speed_abs = std::fabs(v);
  // H(L) = L - ln(1 + w / V*), w = |v_s| = |v| alpha(u) |u|, u = sigma0 z / S(L):
  // w falls as S rises, so H' >= 1 and the root L* is unique; an L below it
  // bounds it from above by ln(1 + w/V*) there, one above from below. Halley's
  // method (H'' from the blend's own slopes) from the guess's L, or from 0,
  // within that bracket, bisecting where a step leaves it.
  double lo = 0.0, hi = HUGE_VAL;
  double log_term = 0.0;
  if (guess_n > 0 && slope > 0) log_term = std::max(0.0, (guess_n - s0) / slope);
  double slip = 0.0, fixed = 0.0;
  // The last slip rate whose logarithm was taken: ln(1 + w / V*) there and
  // 1 / (V* + w) (none: w < 0).
  double reference_w = -1.0, reference_log = 0.0, reference_inverse = 0.0;
  for (int i = 0; i < kSlipRateIterations; ++i) {
    const double s = s_of(log_term);
    const double u = z * sigma0 / s;
    const double alpha = plasticity(r, v, u, 1.0);
    slip = alpha * speed_abs * u;  // signed as z
    const double w = std::fabs(slip);
    const double inverse_level = 1.0 / (v_star + w);
    const double near = (w - reference_w) * reference_inverse;
    if (reference_w >= 0.0 && std::fabs(near) <= kLogNearOneReach) {
      fixed = reference_log + log_near_one(near);
    } else {
      fixed = std::log(1.0 + w * inverse_v_star);
      reference_w = w;
      reference_log = fixed;
      reference_inverse = inverse_level;
    }
    const double h = log_term - fixed;
    if (!(std::fabs(h) * slope > kSlipRateResidual * s)) break;
    if (h < 0) {
      lo = std::max(lo, log_term);
      hi = std::min(hi, fixed);
    } else {
      hi = std::min(hi, log_term);
      lo = std::max(lo, fixed);
    }
    // Derivatives along L: |u|' = -|u| K / S, |u|'' = 2 |u| K^2 / S^2.
    const double uabs = std::fabs(u), ks = slope / s;
    const double du = -uabs * ks, ddu = 2.0 * uabs * ks * ks;
    const BlendSlopes b = blend_slopes(r, alpha);
    const double dphi = alpha + uabs * b.first, ddphi = 2.0 * b.first + uabs * b.second;  // of alpha |u|
    const double dw = speed_abs * dphi * du, ddw = speed_abs * (ddphi * du * du + dphi * ddu);
    const double dh = 1.0 - dw * inverse_level;
    const double ddh = (dw * dw * inverse_level - ddw) * inverse_level;
    const double denominator = 2.0 * dh * dh - h * ddh;
    bool halley = denominator > 0;
    double next = halley ? log_term - 2.0 * h * dh / denominator : log_term - h / dh;
    if (!(next > lo && next < hi)) {
      next = 0.5 * (lo + hi);
      halley = false;
    }
    if (next == log_term || hi - lo <= 1e-15 * hi) break;
    const double step = std::fabs(next - log_term), curvature = ddh / dh;
    if (halley && step <= 1e-3 && slope * step * step * step * (1.0 + curvature * curvature) <= kSlipRateResidual * s) {
      // Halley's step leaves an error of order (H''/H')^2 times its cube
      // (the third derivative's share of the same order): below the
      // residual's tolerance here, S and v_s are taken at next without the
      // logarithm of evaluating H there.
      const double s_next = s_of(next);
      const double u_next = z * sigma0 / s_next;
      c.slip_rate_m_per_s = plasticity(r, v, u_next, 1.0) * speed_abs * u_next;
      return s_next;
    }
    log_term = next;
  }
  c.slip_rate_m_per_s = slip;
  return s_of(fixed);
}

}  // namespace

double stribeck_n_at_deflection(const FrictionModel& m, const FrictionLevels& levels, ContactPoint& c, double z,
                                double guess_n) {
  if (!(levels.rate_state_n > 0) || !direct_effect_on_slip_rate(m.rate_state)) return stribeck_n(m, levels, c);
  return solve_at_deflection(m, levels, point_terms(m, levels, c), c, z, guess_n);
}

SlidingAndStatic stribeck_at_deflection_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                                     ContactPoint& c, double z, double direction, double guess_n) {
  if (!(levels.rate_state_n > 0) || !direct_effect_on_slip_rate(m.rate_state)) {
    return stribeck_and_static_n(m, levels, c, direction);
  }
  const PointTerms t = point_terms(m, levels, c);
  return SlidingAndStatic{solve_at_deflection(m, levels, t, c, z, guess_n), stribeck_at(m, levels, t, kAtRest, direction)};
}

double static_friction_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                         double direction) {
  return stribeck_at(m, levels, point_terms(m, levels, c), kAtRest, direction);
}

SlidingAndStatic stribeck_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                       const ContactPoint& c, double direction) {
  const PointTerms t = point_terms(m, levels, c);
  return SlidingAndStatic{
      stribeck_at(m, levels, t, speed_terms(m, levels, t, c.stribeck_velocity_m_per_s, direct_velocity(m, c)),
                  c.velocity_m_per_s),
      stribeck_at(m, levels, t, kAtRest, direction)};
}

ContactStateRates contact_state_rates(const FrictionModel& m, const ContactPoint& c, double slip_rate) {
  ContactStateRates r;
  if (m.dwell_stiction.enabled) {
    r.contact_age = 1.0 - std::fabs(c.velocity_m_per_s) * c.contact_age_s / m.dwell_stiction.memory_length_m;
  }
  if (m.rate_state.enabled) r.rate_state = rate_state_rate(m.rate_state, slip_rate, c.rate_state_s);
  return r;
}

double modulation_floor(const FrictionModel& m) {
  double floor = 1.0;
  if (m.position_periodic.enabled) floor *= 1.0 - std::fabs(m.position_periodic.amplitude);
  if (m.direction_asymmetry.enabled) floor *= 1.0 - std::fabs(m.direction_asymmetry.ratio);
  return floor;
}

double steady_state_friction_n(const FrictionModel& m, const FrictionLevels& levels, double v,
                               double x) {
  if (!levels.in_contact() || v == 0.0) return 0.0;
  const double age = m.dwell_stiction.memory_length_m / std::fabs(v);
  const double phi = m.rate_state.memory_length_m / (std::fabs(v) + m.rate_state.reference_velocity_m_per_s);
  // In steady sliding the bristle is still: the slip rate is v.
  const double s = stribeck_n(m, levels, ContactPoint{v, v, x, age, phi, v});
  return (v > 0 ? s : -s) + m.lugre.sigma2_n_s_per_m * v;
}

}  // namespace tribo::sim
