#include "daemon/friction_observer.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tribo::daemon {

namespace {

double sign_of(double v) { return v >= 0 ? 1.0 : -1.0; }

// Dupont's alpha(z, v) as tribo-fit evaluates it (analysis/models/friction_model.cc).
double plasticity(double ratio, double v, double z, double g) {
  if ((z > 0) != (v > 0) || z == 0) return 0.0;
  const double zabs = std::fabs(z);
  if (zabs <= ratio * g) return 0.0;
  if (zabs >= g) return 1.0;
  return 0.5 + 0.5 * std::sin(std::numbers::pi * (zabs - 0.5 * (1.0 + ratio) * g) / ((1.0 - ratio) * g));
}

// z after h of dz/dt = drive - a z (a >= 0), exactly.
double relax(double z, double drive, double a, double h) {
  const double u = a * h;
  if (u < 1e-9) return z + drive * h;
  const double e = std::exp(-u);
  return z * e + drive * (1.0 - e) / a;
}

// Dieterich's ageing law over h at speed |v|: exact.
double age_step(double age, double speed, double memory_m, double h) {
  if (speed == 0.0) return age + h;
  const double steady = memory_m / speed;
  return steady + (age - steady) * std::exp(-(speed * h) / memory_m);
}

// Ruina's slip law over h at speed |v|: exact in ln(|v| theta / Dc); at rest theta holds.
double slip_law_step(double theta, double speed, double memory_m, double h) {
  if (speed == 0.0) return theta;
  const double phi = std::log(speed * theta / memory_m);
  return memory_m / speed * std::exp(phi * std::exp(-(speed * h) / memory_m));
}

double floor_speed(const IdentifiedFriction& m) { return 0.01 * m.reference_speed_m_per_s; }

}  // namespace

ObserverState observer_at_rest(const IdentifiedFriction& m) {
  ObserverState s;
  if (m.rate_state && m.rate_state_slip_law && m.reference_speed_m_per_s > 0) {
    s.rate_state_s = m.rate_state_memory_m / m.reference_speed_m_per_s;
  }
  return s;
}

double identified_friction_level(const IdentifiedFriction& m, double speed, double direction, double normal_force_n,
                                 double rate_state_s, double contact_age_s) {
  double static_level = m.static_level;
  if (m.dwell) static_level += m.dwell_gain * (contact_age_s / (contact_age_s + m.dwell_time_s));
  const double ratio = speed / m.stribeck_velocity_m_per_s;
  const double shape = m.stribeck_exponent == 1.0 ? ratio : std::pow(ratio, m.stribeck_exponent);
  double level = m.coulomb + (static_level - m.coulomb) * std::exp(-shape);
  if (m.velocity_strengthening || m.rate_state) {
    const double log_speed = std::log((speed + floor_speed(m)) / m.reference_speed_m_per_s);
    if (m.velocity_strengthening) level += m.log_velocity_coeff * log_speed;
    if (m.rate_state) {
      // theta at least a nanosecond: a state of exactly zero (a contact that
      // has just formed) would give ln 0.
      const double theta = std::max(rate_state_s, 1e-9);
      level += m.rate_state_a * log_speed +
               m.rate_state_b * std::log(m.reference_speed_m_per_s * theta / m.rate_state_memory_m);
    }
  }
  if (m.load_scaled) {
    const double load = std::max(normal_force_n, 0.0);
    level *= load;
    if (m.load_dependence && load > 0) level *= std::pow(load / m.reference_load_n, m.load_exponent);
  }
  if (m.direction_asymmetry) level *= 1.0 + m.asymmetry_levels * direction;
  return std::max(level, 0.0);
}

double identified_friction_bound(const IdentifiedFriction& m, double max_speed, double max_load, double elapsed_s) {
  double level = std::max(m.static_level, m.coulomb) + (m.dwell ? std::max(m.dwell_gain, 0.0) : 0.0);
  if (m.velocity_strengthening || m.rate_state) {
    const double coeff = (m.velocity_strengthening ? m.log_velocity_coeff : 0.0) + (m.rate_state ? m.rate_state_a : 0.0);
    const auto log_speed = [&](double v) { return std::log((v + floor_speed(m)) / m.reference_speed_m_per_s); };
    level += std::max(coeff * log_speed(0.0), coeff * log_speed(std::max(max_speed, 0.0)));
  }
  if (m.rate_state) {
    // theta: from its value at rest, it rises by at most 1 per second with
    // the ageing law (d theta/dt = 1 - |v| theta/Dc) and 1/e per second with
    // the slip law (d theta/dt = -x ln x, x = |v| theta/Dc), and falls no lower
    // than Dc / max_speed in sliding (the slip law), or to the observer's floor.
    const double start = observer_at_rest(m).rate_state_s;
    const double growth_per_s = m.rate_state_slip_law ? 1 / std::numbers::e : 1.0;
    const double highest = start + growth_per_s * std::max(elapsed_s, 0.0);
    const double lowest = m.rate_state_slip_law && max_speed > 0 ? std::min(start, m.rate_state_memory_m / max_speed)
                                                                 : 1e-9;
    const auto state_term = [&](double theta) {
      return m.rate_state_b * std::log(m.reference_speed_m_per_s * std::max(theta, 1e-9) / m.rate_state_memory_m);
    };
    level += std::max(state_term(lowest), state_term(highest));
  }
  level = std::max(level, 0.0);
  if (m.load_scaled) {
    const double load = std::max(max_load, 0.0);
    level *= load;
    // |e| < 1 (the report's bound): N^(1 + e) rises with the load.
    if (m.load_dependence && load > 0) level *= std::pow(load / m.reference_load_n, m.load_exponent);
  }
  if (m.direction_asymmetry) level *= 1 + std::fabs(m.asymmetry_levels);
  return level;
}

ObserverOutput observer_step(const IdentifiedFriction& m, const ObserverSettings& settings, const ObserverInput& in,
                             ObserverState& s) {
  ObserverOutput out;
  const double h = in.period_s;
  if (!std::isfinite(in.position_m) || !std::isfinite(in.position_error_m) || !std::isfinite(in.normal_force_n) ||
      !(h > 0)) {
    return out;
  }
  // v^: the difference of the readings, low-passed (backward Euler, as daemon/signal_filters.h).
  if (s.primed) {
    const double raw = (in.position_m - s.position_m) / h;
    const double tf = settings.velocity_filter_hz > 0 ? 1.0 / (2.0 * std::numbers::pi * settings.velocity_filter_hz) : 0.0;
    s.velocity_m_per_s += h / (tf + h) * (raw - s.velocity_m_per_s);
  }
  s.primed = true;
  s.position_m = in.position_m;
  const double v = settings.velocity == ObserverVelocity::kMeasured ? s.velocity_m_per_s : in.commanded_velocity_m_per_s;
  s.driving_velocity_m_per_s = v;
  const double speed = std::fabs(v), direction = sign_of(v);
  const double state_speed = settings.contact_state_from_measured ? std::fabs(s.velocity_m_per_s) : speed;

  if (m.rate_state) {
    s.rate_state_s = m.rate_state_slip_law ? slip_law_step(s.rate_state_s, state_speed, m.rate_state_memory_m, h)
                                           : age_step(s.rate_state_s, state_speed, m.rate_state_memory_m, h);
  }
  if (m.dwell) s.contact_age_s = age_step(s.contact_age_s, state_speed, m.dwell_memory_m, h);

  const double level = identified_friction_level(m, speed, direction, in.normal_force_n, s.rate_state_s, s.contact_age_s);
  // The largest deflection the contact holds at this load: its static level.
  const double static_level = identified_friction_level(m, 0.0, direction, in.normal_force_n, s.rate_state_s,
                                                        s.contact_age_s);
  const double z_max = std::max(level, static_level) / m.sigma0_n_per_m;
  const double tilt_n = m.tilt_tan * in.normal_force_n;
  double dz_dt = 0;
  if (level <= 0 || z_max <= 0) {
    s.bristle_m = 0;  // out of contact: no bristle
  } else {
    const double g = level / m.sigma0_n_per_m;
    const double alpha = m.elasto_plastic ? plasticity(m.breakaway_ratio, v, s.bristle_m, g) : 1.0;
    const double correction = settings.observer_gain_per_s * in.position_error_m;
    // The bound is a projection, not a motion of the bristle: when the level
    // falls (e.g. a log-velocity term as the command stops) the state is
    // projected onto the new bound before it is differenced, or the damping
    // would kick the drive by sigma1 times the jump over one tick; and a
    // bristle held at the bound (the correction pushing beyond it) does not
    // move. The damping takes the bristle's motion within the bound, never
    // more than its own rate (a projection shortens distances).
    const double before = std::clamp(s.bristle_m, -z_max, z_max);
    s.bristle_m = std::clamp(relax(s.bristle_m, v - correction, alpha * speed / g, h), -z_max, z_max);
    dz_dt = (s.bristle_m - before) / h;
  }
  const double viscous = m.direction_asymmetry ? m.viscous_n_s_per_m * (1.0 + m.asymmetry_viscous * direction)
                                               : m.viscous_n_s_per_m;
  out.friction_n = m.sigma0_n_per_m * s.bristle_m + m.sigma1_n_s_per_m * dz_dt + viscous * v;
  out.force_n = out.friction_n + tilt_n;
  out.advanced = true;
  return out;
}

}  // namespace tribo::daemon
