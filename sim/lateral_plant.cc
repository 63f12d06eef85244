#include "sim/lateral_plant.h"

#include "sim/compact_rk4.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

double tip_position_m(const LateralPlant& plant, const LateralState& s) {
  return plant.axis.backlash.enabled ? s.tip_position_m : s.position_m;
}

double tip_velocity_m_per_s(const LateralPlant& plant, const LateralState& s) {
  return plant.axis.backlash.enabled ? s.tip_velocity_m_per_s : s.velocity_m_per_s;
}

namespace {

int slip_elements(const LateralPlant& plant) {
  const PreslidingHysteresisParams& h = plant.friction.presliding_hysteresis;
  return h.enabled ? h.elements : 0;
}

ContactPoint contact_point(const LateralPlant& plant, const LateralInputs& in, const LateralState& s) {
  const double v = tip_velocity_m_per_s(plant, s) - in.sample_velocity_m_per_s;
  return ContactPoint{v, plant.friction.frictional_lag.enabled ? s.lag_velocity_m_per_s : v,
                      tip_position_m(plant, s) - in.sample_offset_m, s.contact_age_s, s.rate_state_s};
}

// Friction force of the bristle(s) at deflection scale g (1/g = q); fills their rates.
double bristle_force_n(const FrictionModel& m, double g, double q, double v, const LateralState& s,
                       LateralEvaluation& e) {
  const LugreParams& p = m.lugre;
  const PreslidingHysteresisParams& h = m.presliding_hysteresis;
  LateralRate& r = e.rate;
  if (!h.enabled) {
    const LugreOutput out = lugre_bristle_at_inverse_scale(p, q, v, s.bristle_m);
    r.bristle_m = out.dz_dt_m_per_s;
    e.plasticity = out.plasticity;
    return out.force_n;
  }
  double force = p.sigma2_n_s_per_m * v;
  const double share = 1.0 / h.elements;
  for (int i = 0; i < h.elements; ++i) {
    const double gi = slip_share(h, i) * g;
    const double z = s.slip_m[i];
    const double dz = v - plasticity(h.breakaway_ratio, v, z, gi) * std::fabs(v) * z / gi;
    r.slip_m[i] = dz;
    force += share * (p.sigma0_n_per_m * z + p.sigma1_n_s_per_m * dz);
  }
  return force;
}

// The slip rate at the interface: the tip's velocity less the bristles'
// elastic deflection rate (their mean, with Maxwell-slip elements). The
// rate-and-state state evolves with slip, not with elastic loading.
double slip_rate_m_per_s(const LateralPlant& plant, double v, const LateralRate& r) {
  const PreslidingHysteresisParams& h = plant.friction.presliding_hysteresis;
  if (!h.enabled) return v - r.bristle_m;
  double mean = 0;
  for (int i = 0; i < h.elements; ++i) mean += r.slip_m[i];
  return v - mean / h.elements;
}

}  // namespace

LateralEvaluation lateral_derivative(const LateralPlant& plant, const LateralInputs& in,
                                     const LateralState& s, const double* stribeck_n_at_s) {
  const LateralAxisParams& axis = plant.axis;
  const FrictionModel& m = plant.friction;
  LateralEvaluation e;
  LateralRate& r = e.rate;
  ContactPoint c = contact_point(plant, in, s);
  if (in.levels.in_contact()) {
    const double stribeck = stribeck_n_at_s ? *stribeck_n_at_s : stribeck_n_at_deflection(m, in.levels, c, s.bristle_m);
    const double g = stribeck / m.lugre.sigma0_n_per_m;
    e.deflection_scale_m = g;
    e.inverse_scale_per_m = m.lugre.sigma0_n_per_m / stribeck;
    e.friction_n = bristle_force_n(m, g, e.inverse_scale_per_m, c.velocity_m_per_s, s, e);
    if (m.dwell_stiction.enabled || m.rate_state.enabled) {
      const ContactStateRates slow = contact_state_rates(m, c, slip_rate_m_per_s(plant, c.velocity_m_per_s, r));
      r.contact_age_s = slow.contact_age;
      r.rate_state_s = slow.rate_state;
    }
  } else {
    for (int i = 0; i < slip_elements(plant); ++i) r.slip_m[i] = 0;  // out of contact nothing slips
  }
  if (m.frictional_lag.enabled) {
    r.lag_velocity_m_per_s = (c.velocity_m_per_s - s.lag_velocity_m_per_s) / m.frictional_lag.time_constant_s;
  }
  const double plate_n = in.drive.force_n(s.position_m) - axis.spring_n_per_m * s.position_m -
                         axis.damping_n_s_per_m * s.velocity_m_per_s;
  r.position_m = s.velocity_m_per_s;
  if (!axis.backlash.enabled) {
    r.velocity_m_per_s = (plate_n - e.friction_n + in.tip_force_n) / axis.mass_kg;
  } else {
    const BacklashParams& b = axis.backlash;
    const double play = 0.5 * b.width_m, d = s.position_m - s.tip_position_m;
    double coupling_n = 0;
    if (std::fabs(d) > play) {
      coupling_n = b.coupling_stiffness_n_per_m * (d > 0 ? d - play : d + play) +
                   b.coupling_damping_n_s_per_m * (s.velocity_m_per_s - s.tip_velocity_m_per_s);
    }
    r.velocity_m_per_s = (plate_n - coupling_n) / (axis.mass_kg - b.tip_mass_kg);
    r.tip_position_m = s.tip_velocity_m_per_s;
    r.tip_velocity_m_per_s = (coupling_n - e.friction_n + in.tip_force_n) / b.tip_mass_kg;
  }
  hold_at_stop(in.drive, s.position_m, r.position_m, r.velocity_m_per_s);
  return e;
}

namespace {

// out = s + h r over the states in use (n Maxwell-slip elements).
template <class State>
void add_scaled(State& out, const State& s, const LateralRate& r, double h, int n) {
  out.position_m = s.position_m + h * r.position_m;
  out.velocity_m_per_s = s.velocity_m_per_s + h * r.velocity_m_per_s;
  out.tip_position_m = s.tip_position_m + h * r.tip_position_m;
  out.tip_velocity_m_per_s = s.tip_velocity_m_per_s + h * r.tip_velocity_m_per_s;
  out.bristle_m = s.bristle_m + h * r.bristle_m;
  out.lag_velocity_m_per_s = s.lag_velocity_m_per_s + h * r.lag_velocity_m_per_s;
  out.contact_age_s = s.contact_age_s + h * r.contact_age_s;
  out.rate_state_s = s.rate_state_s + h * r.rate_state_s;
  for (int i = 0; i < n; ++i) out.slip_m[i] = s.slip_m[i] + h * r.slip_m[i];
}

// One sub-step (classical RK4 or the explicit midpoint rule); with
// frozen_contact the contact states keep their value.
void substep(const LateralPlant& plant, const LateralInputs& in, double h, bool frozen_contact,
             SubstepScheme scheme, LateralState& s, const LateralRate* first = nullptr) {
  const int n = slip_elements(plant);
  auto rate = [&](const LateralState& at) {
    LateralRate r = lateral_derivative(plant, in, at).rate;
    if (frozen_contact) {
      r.bristle_m = 0;
      r.contact_age_s = 0;
      r.rate_state_s = 0;
      for (int i = 0; i < n; ++i) r.slip_m[i] = 0;
    }
    return r;
  };
  LateralState tmp = s;
  const LateralRate k1 = first ? *first : rate(s);
  if (scheme == SubstepScheme::kMidpoint) {
    add_scaled(tmp, s, k1, h / 2, n);
    add_scaled(s, s, rate(tmp), h, n);
    return;
  }
  add_scaled(tmp, s, k1, h / 2, n);
  const LateralRate k2 = rate(tmp);
  add_scaled(tmp, s, k2, h / 2, n);
  const LateralRate k3 = rate(tmp);
  add_scaled(tmp, s, k3, h, n);
  const LateralRate k4 = rate(tmp);
  LateralRate sum = k1;
  add_scaled(sum, k1, k2, 2.0, n);
  add_scaled(sum, sum, k3, 2.0, n);
  add_scaled(sum, sum, k4, 1.0, n);
  add_scaled(s, s, sum, h / 6, n);
}

// Solution of dz/dt = v - alpha a z over h for frozen v and alpha (a = |v|/g):
// exact for plain LuGre. With elasto-plastic presliding alpha rises to 1 as
// |z| reaches the steady deflection g_ss, so a bristle loading towards it
// stops there instead of at the frozen-alpha target g/alpha. g_ss is g
// unless S depends on z (the direct effect on the slip rate): then g is S at
// the present z's slip rate, below the steady S at slip rate |v|, and a
// bristle held at that g sits in the blend (alpha ~ 0) with dz/dt ~ v.
double relax_bristle(double breakaway_ratio, double g, double g_ss, double v, double z, double h) {
  if (v == 0.0) return z;
  const double alpha = plasticity(breakaway_ratio, v, z, g);
  const double rate = alpha * std::fabs(v) / g;
  double next = rate > 0 ? v / rate + (z - v / rate) * std::exp(-rate * h) : z + v * h;
  const double limit = v > 0 ? g_ss : -g_ss;
  const bool was_inside = std::fabs(z) <= g_ss;
  if (was_inside && (v > 0 ? next > limit : next < limit)) next = limit;
  return next;
}

// The slip rate alpha |v| z / g of the bristle(s) at deflection scale g.
double bristle_slip_rate_m_per_s(const FrictionModel& m, double g, double v, const LateralState& s) {
  const PreslidingHysteresisParams& hy = m.presliding_hysteresis;
  if (!hy.enabled) return plasticity(m.lugre.breakaway_ratio, v, s.bristle_m, g) * std::fabs(v) * s.bristle_m / g;
  double slip = 0;
  for (int i = 0; i < hy.elements; ++i) {
    const double gi = slip_share(hy, i) * g;
    slip += plasticity(hy.breakaway_ratio, v, s.slip_m[i], gi) * std::fabs(v) * s.slip_m[i] / gi / hy.elements;
  }
  return slip;
}

// Half of the Strang split: the contact states, exact for frozen v and g.
// With rate-and-state, g depends on the state and the state's rate on the
// bristle's slip, so they are split symmetrically too: the state for h/2,
// the bristle(s) for h, the state for h/2 (second order in h).
void relax_contact(const LateralPlant& plant, const LateralInputs& in, double h, LateralState& s) {
  if (!in.levels.in_contact()) return;
  const FrictionModel& m = plant.friction;
  const double v = contact_point(plant, in, s).velocity_m_per_s;
  auto relax_state = [&](double step) {
    if (!m.rate_state.enabled) return;
    ContactPoint c = contact_point(plant, in, s);
    const double g = stribeck_n_at_deflection(m, in.levels, c, s.bristle_m) / m.lugre.sigma0_n_per_m;
    s.rate_state_s = relax_rate_state(m.rate_state, bristle_slip_rate_m_per_s(m, g, v, s), s.rate_state_s, step);
  };
  relax_state(h / 2);
  ContactPoint c = contact_point(plant, in, s);
  const double g = stribeck_n_at_deflection(m, in.levels, c, s.bristle_m) / m.lugre.sigma0_n_per_m;
  const PreslidingHysteresisParams& hy = m.presliding_hysteresis;
  if (!hy.enabled) {
    // In steady sliding dz/dt = 0: the slip rate is v and |z| = g there.
    double g_ss = g;
    if (in.levels.rate_state_n > 0 && direct_effect_on_slip_rate(m.rate_state)) {
      c.slip_rate_m_per_s = v;
      g_ss = stribeck_n(m, in.levels, c) / m.lugre.sigma0_n_per_m;
    }
    s.bristle_m = relax_bristle(m.lugre.breakaway_ratio, g, g_ss, v, s.bristle_m, h);
  } else {
    for (int i = 0; i < hy.elements; ++i) {
      const double gi = slip_share(hy, i) * g;
      s.slip_m[i] = relax_bristle(hy.breakaway_ratio, gi, gi, v, s.slip_m[i], h);
    }
  }
  relax_state(h / 2);
  if (m.dwell_stiction.enabled) {
    const double rate = std::fabs(v) / m.dwell_stiction.memory_length_m;
    s.contact_age_s = rate > 0 ? 1 / rate + (s.contact_age_s - 1 / rate) * std::exp(-rate * h)
                               : s.contact_age_s + h;
  }
}

}  // namespace

bool integrate_lateral(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                       int substeps, LateralState& s, const LateralRate* first, SubstepScheme scheme) {
  if (compact_rk4_applies(plant, s)) return integrate_lateral_compact(plant, in, dt_s, substeps, s, first, scheme);
  return integrate_lateral_general(plant, in, dt_s, substeps, s, first, scheme);
}

bool integrate_lateral_general(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                               int substeps, LateralState& s, const LateralRate* first, SubstepScheme scheme) {
  const double h = dt_s / substeps;
  bool stopped = false;
  for (int i = 0; i < substeps; ++i) {
    substep(plant, in, h, false, scheme, s, i == 0 ? first : nullptr);
    stopped |= apply_stops(in.drive, s.position_m, s.velocity_m_per_s);
  }
  return stopped;
}

bool integrate_lateral_split(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                             int substeps, LateralState& s, SubstepScheme scheme) {
  const double h = dt_s / substeps;
  bool stopped = false;
  for (int i = 0; i < substeps; ++i) {
    relax_contact(plant, in, h / 2, s);
    substep(plant, in, h, true, scheme, s);
    stopped |= apply_stops(in.drive, s.position_m, s.velocity_m_per_s);
    relax_contact(plant, in, h / 2, s);
  }
  return stopped;
}

double limit_to_static_friction(const LateralPlant& plant, const LateralInputs& in, LateralState& s,
                                double guess_n) {
  if (!in.levels.in_contact()) return 0.0;
  const FrictionModel& m = plant.friction;
  const ContactPoint c = contact_point(plant, in, s);
  auto limit = [&](double z, double share, double sliding_n, double static_n) {
    const double held_n = std::max(sliding_n, static_n);
    const double most = share * held_n / m.lugre.sigma0_n_per_m;
    return std::clamp(z, -most, most);
  };
  const PreslidingHysteresisParams& hy = m.presliding_hysteresis;
  if (!hy.enabled) {
    // S sliding and at rest share the point's terms: one evaluation of them.
    if (!direct_effect_on_slip_rate(m.rate_state)) {
      const SlidingAndStatic both = stribeck_and_static_n(m, in.levels, c, s.bristle_m);
      s.bristle_m = limit(s.bristle_m, 1.0, both.sliding_n, both.static_n);
      return both.sliding_n;
    }
    // S sliding depends on the bristle through the slip rate: at the
    // deflection the limit leaves (the caller's next evaluation's S).
    ContactPoint at = c;
    const SlidingAndStatic both =
        stribeck_at_deflection_and_static_n(m, in.levels, at, s.bristle_m, s.bristle_m, guess_n);
    const double before = s.bristle_m;
    s.bristle_m = limit(s.bristle_m, 1.0, both.sliding_n, both.static_n);
    if (s.bristle_m == before) return both.sliding_n;
    at = c;
    return stribeck_n_at_deflection(m, in.levels, at, s.bristle_m, both.sliding_n);
  }
  const double sliding_n = stribeck_n(m, in.levels, c);
  for (int i = 0; i < hy.elements; ++i) {
    s.slip_m[i] = limit(s.slip_m[i], slip_share(hy, i), sliding_n, static_friction_n(m, in.levels, c, s.slip_m[i]));
  }
  return sliding_n;
}

double stored_energy_j(const LateralPlant& plant, const LateralInputs& in, const LateralState& s) {
  const LateralAxisParams& axis = plant.axis;
  const LugreParams& p = plant.friction.lugre;
  const BacklashParams& b = axis.backlash;
  const double plate_mass = b.enabled ? axis.mass_kg - b.tip_mass_kg : axis.mass_kg;
  double e = 0.5 * plate_mass * s.velocity_m_per_s * s.velocity_m_per_s +
             0.5 * axis.spring_n_per_m * s.position_m * s.position_m + in.drive.potential_j(s.position_m) -
             in.tip_force_n * tip_position_m(plant, s);
  if (b.enabled) {
    const double play = 0.5 * b.width_m, d = s.position_m - s.tip_position_m;
    const double stretch = std::fabs(d) > play ? std::fabs(d) - play : 0.0;
    e += 0.5 * b.tip_mass_kg * s.tip_velocity_m_per_s * s.tip_velocity_m_per_s +
         0.5 * b.coupling_stiffness_n_per_m * stretch * stretch;
  }
  const PreslidingHysteresisParams& h = plant.friction.presliding_hysteresis;
  if (!h.enabled) {
    e += 0.5 * p.sigma0_n_per_m * s.bristle_m * s.bristle_m;
  } else {
    for (int i = 0; i < h.elements; ++i) e += 0.5 * p.sigma0_n_per_m / h.elements * s.slip_m[i] * s.slip_m[i];
  }
  return e;
}

}  // namespace tribo::sim
