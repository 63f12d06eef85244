#include "sim/friction_effects.h"

#include <algorithm>
#include <cmath>
#include <numbers>

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

// log1p(e) for |e| <= kAnchorReach: its Taylor series to e^9 (the rest is
// below e^10 / 10 = 9e-17), summed in Estrin's pairs (a short dependency chain).
double log1p_series(double e) {
  const double e2 = e * e, e4 = e2 * e2, e8 = e4 * e4;
  const double p0 = 1.0 - 0.5 * e, p1 = 1.0 / 3 - 0.25 * e, p2 = 0.2 - (1.0 / 6) * e, p3 = 1.0 / 7 - 0.125 * e;
  return e * (((p0 + e2 * p1) + e4 * (p2 + e2 * p3)) + e8 * (1.0 / 9));
}

// log1p(e) for |e| <= kStateReach (the state's steps): to e^4 (the rest is
// below e^5 / 5 = 1.8e-16).
double log1p_short_series(double e) {
  const double e2 = e * e;
  return e * ((1.0 - 0.5 * e) + e2 * (1.0 / 3 - 0.25 * e));
}

// exp(-d) for |d| <= kAnchorReach: its Taylor series to d^7 (the rest is
// below d^8 / 8! = 2.3e-17).
double exp_neg_series(double d) {
  const double d2 = d * d, d4 = d2 * d2;
  const double p0 = 1.0 - d, p1 = 0.5 - (1.0 / 6) * d, p2 = 1.0 / 24 - (1.0 / 120) * d, p3 = 1.0 / 720 - (1.0 / 5040) * d;
  return (p0 + d2 * p1) + d4 * (p2 + d2 * p3);
}

// ln(max(V* phi / D_c, floor)): from the anchor when phi is near its phi.
double state_log_at(const RateStateParams& r, double phi, const ContactAnchor* a) {
  if (a && a->state_scale > 0) {
    const double e = (phi - a->state) * a->state_scale;
    if (std::fabs(e) <= kStateReach) return a->state_log + log1p_short_series(e);
    return std::log(std::max(phi * a->state_per_memory, kMinRateStateRatio));
  }
  return std::log(std::max(phi * (r.reference_velocity_m_per_s / r.memory_length_m), kMinRateStateRatio));
}

// ln(1 + speed / V*): from the anchor's (base, scale) when speed is near its own.
double speed_log_at(const RateStateParams& r, double speed, double anchor_speed, double anchor_log, double scale,
                    const ContactAnchor* a) {
  if (a) {
    const double e = (speed - anchor_speed) * scale;
    if (std::fabs(e) <= kAnchorReach) return anchor_log + log1p_series(e);
  }
  return std::log1p(speed * (1.0 / r.reference_velocity_m_per_s));
}

PointTerms point_terms(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                       const ContactAnchor* anchor = nullptr) {
  PointTerms t;
  t.fs = levels.static_n;
  if (m.dwell_stiction.enabled) {
    const double age = c.contact_age_s;
    const double d = anchor ? (age - anchor->age) * anchor->age_scale : 0.0;
    if (anchor && std::fabs(d) <= kDwellReach) {  // age / (age + gamma) = 1 - gamma / (age + gamma)
      const double inverse = anchor->age_scale * (1.0 - d + d * d);
      t.fs *= 1.0 + m.dwell_stiction.gain * (1.0 - m.dwell_stiction.time_constant_s * inverse);
    } else {
      t.fs *= 1.0 + m.dwell_stiction.gain * age / (age + m.dwell_stiction.time_constant_s);
    }
  }
  if (levels.rate_state_n > 0) {
    t.state_log = state_log_at(m.rate_state, c.rate_state_s, anchor);
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

SpeedTerms speed_terms(const FrictionModel& m, const FrictionLevels& levels, double vs,
                       const ContactAnchor* a = nullptr) {
  SpeedTerms t;
  const double speed = std::fabs(vs);
  const double d = a ? (speed - a->speed) * a->inv_stribeck_velocity : 0.0;
  if (a && m.lugre.stribeck_exponent == 1.0 && std::fabs(d) <= kAnchorReach) {
    t.shape = a->shape * exp_neg_series(d);
  } else {
    t.shape = stribeck_shape(m.lugre, vs);
  }
  if (levels.strengthening_n > 0) {
    t.strengthening_log = std::log1p(std::fabs(vs) / m.velocity_strengthening.reference_velocity_m_per_s);
  }
  if (levels.rate_state_n > 0) {
    t.direct_log = a ? speed_log_at(m.rate_state, speed, a->speed, a->direct_log, a->direct_scale, a)
                     : std::log1p(speed * (1.0 / m.rate_state.reference_velocity_m_per_s));
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

}  // namespace

double stribeck_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c) {
  return stribeck_at(m, levels, point_terms(m, levels, c), speed_terms(m, levels, c.stribeck_velocity_m_per_s),
                     c.velocity_m_per_s);
}

double static_friction_n(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                         double direction) {
  return stribeck_at(m, levels, point_terms(m, levels, c), kAtRest, direction);
}

namespace {
ContactAnchor anchor_from(const FrictionModel& m, const ContactPoint& c, double shape, double direct_log,
                          double state_log);
}  // namespace

SlidingAndStatic stribeck_and_static_n(const FrictionModel& m, const FrictionLevels& levels,
                                       const ContactPoint& c, double direction, ContactAnchor* anchor) {
  const PointTerms t = point_terms(m, levels, c);
  const SpeedTerms speed = speed_terms(m, levels, c.stribeck_velocity_m_per_s);
  if (anchor && levels.rate_state_n > 0) *anchor = anchor_from(m, c, speed.shape, speed.direct_log, t.state_log);
  return SlidingAndStatic{stribeck_at(m, levels, t, speed, c.velocity_m_per_s), stribeck_at(m, levels, t, kAtRest, direction)};
}

namespace {

// The anchor at c from the values of its three transcendental terms.
ContactAnchor anchor_from(const FrictionModel& m, const ContactPoint& c, double shape, double direct_log,
                          double state_log) {
  const RateStateParams& r = m.rate_state;
  ContactAnchor a;
  a.valid = true;
  a.speed = std::fabs(c.stribeck_velocity_m_per_s);
  a.shape = shape;
  a.direct_log = direct_log;
  a.direct_scale = 1.0 / (r.reference_velocity_m_per_s + a.speed);
  a.state = c.rate_state_s;
  // Twice the floor: a state within the reach of this one stays above it.
  if (a.state * (r.reference_velocity_m_per_s / r.memory_length_m) > 2 * kMinRateStateRatio) {
    a.state_log = state_log;
    a.state_scale = 1.0 / a.state;
  }
  a.age = c.contact_age_s;
  a.age_scale = 1.0 / (a.age + m.dwell_stiction.time_constant_s);
  a.inv_stribeck_velocity = 1.0 / m.lugre.stribeck_velocity_m_per_s;
  a.state_per_memory = r.reference_velocity_m_per_s / r.memory_length_m;
  a.inv_memory = 1.0 / r.memory_length_m;
  a.inv_dwell_memory = 1.0 / m.dwell_stiction.memory_length_m;
  return a;
}

}  // namespace

void set_anchor_slip(const FrictionModel& m, double slip_rate, ContactAnchor& a) {
  const RateStateParams& r = m.rate_state;
  a.slip = std::fabs(slip_rate);
  a.slip_log = std::log1p(a.slip * (1.0 / r.reference_velocity_m_per_s));
  a.slip_scale = 1.0 / (r.reference_velocity_m_per_s + a.slip);
}

ContactAnchor contact_anchor(const FrictionModel& m, const ContactPoint& c, double slip_rate) {
  const double speed = std::fabs(c.stribeck_velocity_m_per_s);
  const RateStateParams& r = m.rate_state;
  ContactAnchor a = anchor_from(m, c, stribeck_shape(m.lugre, speed),
                                std::log1p(speed * (1.0 / r.reference_velocity_m_per_s)),
                                std::log(std::max(c.rate_state_s * (r.reference_velocity_m_per_s / r.memory_length_m),
                                                  kMinRateStateRatio)));
  set_anchor_slip(m, slip_rate, a);
  return a;
}

NearStribeck stribeck_n_near(const FrictionModel& m, const FrictionLevels& levels, const ContactPoint& c,
                             const ContactAnchor& anchor) {
  const PointTerms t = point_terms(m, levels, c, &anchor);
  return NearStribeck{
      stribeck_at(m, levels, t, speed_terms(m, levels, c.stribeck_velocity_m_per_s, &anchor), c.velocity_m_per_s),
      t.state_log};
}

double rate_state_rate_near(const RateStateParams& p, double v, double phi, double state_log,
                            const ContactAnchor& a) {
  const double x = (std::fabs(v) + p.reference_velocity_m_per_s) * (phi * a.inv_memory);
  if (p.law == StateLaw::kAgeing) return 1.0 - x;
  // ln x = ln(V* phi / D_c) + ln(1 + |v_s| / V*) while the first is above its floor.
  if (!(phi * a.state_per_memory > kMinRateStateRatio)) {
    return x > 0 ? -x * std::log(x) : 0.0;
  }
  return -x * (state_log + speed_log_at(p, std::fabs(v), a.slip, a.slip_log, a.slip_scale, &a));
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
  const double s = stribeck_n(m, levels, ContactPoint{v, v, x, age, phi});
  return (v > 0 ? s : -s) + m.lugre.sigma2_n_s_per_m * v;
}

}  // namespace tribo::sim
