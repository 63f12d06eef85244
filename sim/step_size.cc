#include "sim/step_size.h"

#include "sim/held_contact.h"
#include "sim/quarter_sine.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace tribo::sim {

namespace {

// |lambda| of lambda^2 + B lambda + K = 0 (the larger root's magnitude).
double second_order_rate(double damping, double stiffness) {
  const double disc = 0.25 * damping * damping - stiffness;
  return disc >= 0 ? 0.5 * damping + std::sqrt(disc) : std::sqrt(stiffness);
}

// An upper bound on |ln x| for a normal x > 0, within ln 2 of it, from its
// binary exponent e (2^e <= x < 2^(e+1)): no call to log for a bound.
double log_magnitude_bound(double x) {
  const int e = static_cast<int>((std::bit_cast<std::uint64_t>(x) >> 52) & 0x7ff) - 1023;
  return (e >= 0 ? e + 1 : -e) * std::numbers::ln2;
}

}  // namespace

LateralRates lateral_rate_bounds(const LateralPlant& plant, const LateralInputs& in,
                                 const LateralState& s, const LateralEvaluation& now, double dt_s) {
  return lateral_rate_bounds(plant, in, s, now, dt_s, true);
}

LateralRates lateral_rate_bounds(const LateralPlant& plant, const LateralInputs& in,
                                 const LateralState& s, const LateralEvaluation& now, double dt_s,
                                 bool with_split, double enough_per_s) {
  const LateralAxisParams& axis = plant.axis;
  const BacklashParams& b = axis.backlash;
  const FrictionModel& m = plant.friction;
  const LugreParams& p = m.lugre;
  const bool contact = in.levels.in_contact();
  const double k_plate = axis.spring_n_per_m - in.drive.negative_stiffness_n_per_m(s.position_m);
  const double lag = m.frictional_lag.enabled ? 1.0 / m.frictional_lag.time_constant_s : 0.0;

  // The plate's own mode when a backlash separates it from the tip.
  double plate_rate = 0, friction_mass = axis.mass_kg, contact_damping = axis.damping_n_s_per_m,
         contact_spring = k_plate;
  if (b.enabled) {
    const double plate_mass = axis.mass_kg - b.tip_mass_kg;
    plate_rate = second_order_rate((axis.damping_n_s_per_m + b.coupling_damping_n_s_per_m) / plate_mass,
                                   (k_plate + b.coupling_stiffness_n_per_m) / plate_mass);
    friction_mass = b.tip_mass_kg;
    contact_damping = b.coupling_damping_n_s_per_m;
    contact_spring = b.coupling_stiffness_n_per_m;
  }
  const auto mechanical = [&](double d) {
    const double sigma0 = contact ? p.sigma0_n_per_m : 0.0, sigma1 = contact ? p.sigma1_n_s_per_m : 0.0;
    return plate_rate + second_order_rate((contact_damping + sigma1 * d + (contact ? p.sigma2_n_s_per_m : 0.0)) / friction_mass,
                                          (contact_spring + sigma0 * d) / friction_mass);
  };
  if (!contact) {
    const double rate = mechanical(0.0) + lag;
    return LateralRates{rate, rate};
  }

  const double accel = std::fabs(b.enabled ? now.rate.tip_velocity_m_per_s : now.rate.velocity_m_per_s);
  const double v = tip_velocity_m_per_s(plant, s) - in.sample_velocity_m_per_s;
  const double v_reach = std::fabs(v) + accel * dt_s;
  const bool may_reverse = std::fabs(v) <= accel * dt_s;

  // Extremes of the deflection scale g over positions, directions and ages.
  const double floor = modulation_floor(m);
  const double dwell = m.dwell_stiction.enabled ? 1.0 + std::max(0.0, m.dwell_stiction.gain) : 1.0;
  const double f_min = std::min(in.levels.static_n, in.levels.coulomb_n) *
                       (in.levels.rate_state_n > 0 ? kRateStateFloor : 1.0) * floor;
  const PreslidingHysteresisParams& hy = m.presliding_hysteresis;
  const double share_min = hy.enabled ? 1.0 - hy.spread : 1.0;
  const double share_max = hy.enabled ? 1.0 + hy.spread : 1.0;
  // |v| g'(v) / g = |v| S'(v) / S: its numerator bounded over the Stribeck
  // curve, (Fs D - Fc)/e + Fvs + a N; S at least the smaller of Fc and half
  // its present value (no effect halves S within a tick at h lambda <= 1),
  // and never below its floor f_min.
  const double present_n = now.deflection_scale_m * p.sigma0_n_per_m;
  const double shape = ((in.levels.static_n * dwell - in.levels.coulomb_n) / std::numbers::e +
                        in.levels.strengthening_n + in.levels.rate_state_n * m.rate_state.direct_coeff) /
                       std::max(f_min, std::min(in.levels.coulomb_n, 0.5 * present_n));

  // The present deflection scale (as 1/g, the evaluation's) and how deep the
  // bristle sits in it.
  const double q = hy.enabled ? now.inverse_scale_per_m / share_min : now.inverse_scale_per_m;
  double z_ratio = 0, d = 0;
  const double r = hy.enabled ? hy.breakaway_ratio : p.breakaway_ratio;
  // Within the elasto-plastic blend's elastic range for the whole tick
  // (alpha = 0 wherever the bristle can be, with a factor 2 on its reach)
  // dz/dt = v exactly: d = 1 and no relaxation, whatever g does.
  bool elastic = false;
  if (!hy.enabled) {
    z_ratio = std::fabs(s.bristle_m) * q;
    elastic = r > 0 && z_ratio + 2.0 * v_reach * dt_s * q <= r;
    // alpha at g = the evaluation's own g (share_min is 1 here): the same value.
    const double alpha = now.plasticity;
    const double along = v > 0 ? s.bristle_m * q : (v < 0 ? -s.bristle_m * q : 0.0);
    d = elastic ? 1.0
        : may_reverse ? 1.0 + z_ratio * (1.0 + shape)
                      : std::fabs(1.0 - alpha * along) + z_ratio * shape;
  } else {
    for (int i = 0; i < hy.elements; ++i) z_ratio = std::max(z_ratio, std::fabs(s.slip_m[i]) * q);
    d = 1.0 + z_ratio * (1.0 + shape);
  }
  // |d(alpha |v| z / g)/dz| <= (|v| / g)(1 + (|z|/g) g dalpha/dz). The sine
  // blend's slope g dalpha/dz = pi / (2 (1 - r)) cos(pi (|z|/g - (1 + r)/2) / (1 - r))
  // peaks mid-blend at pi / (2 (1 - r)) and is 0 at both ends; where that
  // peak keeps the estimate under enough_per_s it is taken, else the slope
  // is bounded over the |z|/g the tick can reach (the elastic contact at rest
  // and steady sliding at |z| = g see little of it).
  double steepest = elastic ? 0.0 : 1.0, lo = 0, hi = 0;
  bool in_blend = false;
  if (r > 0 && !elastic) {
    const double reach = v_reach * dt_s * q;
    lo = z_ratio - reach;
    hi = z_ratio + reach;
    in_blend = hi > r && lo < 1.0;
    if (in_blend) steepest = 1.0 + std::min(hi, 1.0) * std::numbers::pi / (2.0 * (1.0 - r));
  }

  double periodic = 0;  // times |z| / g
  if (m.position_periodic.enabled) {
    const auto& pp = m.position_periodic;
    periodic = v_reach * 2 * std::numbers::pi * std::fabs(pp.amplitude) /
               (pp.period_m * (1 - std::fabs(pp.amplitude)));
  }
  double ageing = m.dwell_stiction.enabled ? v_reach / m.dwell_stiction.memory_length_m : 0.0;
  if (m.rate_state.enabled) {  // |d(dphi/dt)/dphi| = r (ageing), r (|ln(r phi)| + 1) (slip); r = (|v| + V*)/D_c
    const double rate = (v_reach + m.rate_state.reference_velocity_m_per_s) / m.rate_state.memory_length_m;
    const double x = rate * s.rate_state_s;
    const double slope = m.rate_state.law == StateLaw::kSlip && x > 0 ? log_magnitude_bound(x) + 1.0 : 1.0;
    ageing += rate * slope;
  }
  const double rest = mechanical(d) + (elastic ? 0.0 : periodic * z_ratio) + ageing + lag;
  double full = rest + v_reach * q * steepest;
  if (in_blend && full > enough_per_s) {
    const double mid = 0.5 * (1.0 + r);
    const double nearest = std::clamp(mid, lo, hi);  // where the slope is largest within reach
    // cos of an angle within [-pi/2, pi/2] (nearest lies between r and 1) as
    // the sine of its distance to pi/2, by sim/quarter_sine.h.
    const double angle = std::numbers::pi * (nearest - mid) / (1.0 - r);
    const double slope = std::numbers::pi / (2.0 * (1.0 - r)) * sine_on_quarter(std::numbers::pi / 2 - std::fabs(angle));
    full = rest + v_reach * q * (1.0 + std::min(hi, 1.0) * std::max(0.0, slope));
  }
  if (!with_split) return LateralRates{full, 0.0};

  // The split scheme's rate: d at its bound over the largest g the tick can reach.
  const double strengthening =
      in.levels.strengthening_n > 0
          ? in.levels.strengthening_n * std::log1p(v_reach / m.velocity_strengthening.reference_velocity_m_per_s)
          : 0.0;
  const double rate_state = std::max(0.0, rate_state_n(m, in.levels, v_reach, s.rate_state_s + dt_s));
  const double f_max = (std::max(in.levels.static_n * dwell, in.levels.coulomb_n) + strengthening + rate_state) / floor;
  const double ratio_max = f_max * share_max / (f_min * share_min);
  const double d_bound = 1.0 + ratio_max * (1.0 + shape);
  return LateralRates{full, mechanical(d_bound) + periodic * ratio_max + lag};
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
  const double split = wanted_substeps(rates.split_per_s, dt_s, max_h_lambda);
  // The split scheme is exact in the contact relaxation: take it when that
  // relaxation is what would make RK4 take many more sub-steps.
  if (full <= max_substeps && full <= kSplitAdvantage * split) {
    return StepPlan{static_cast<int>(full), false, false};
  }
  if (split <= max_substeps) return StepPlan{static_cast<int>(split), true, false};
  return StepPlan{max_substeps, true, true};
}

namespace {

// A tick's result is sane when it is finite and the bristles stay within a
// few times their largest possible deflection.
bool sane(const LateralPlant& plant, const LateralInputs& in, const LateralState& s) {
  if (!std::isfinite(s.position_m) || !std::isfinite(s.velocity_m_per_s) || !std::isfinite(s.bristle_m) ||
      !std::isfinite(s.tip_velocity_m_per_s)) {
    return false;
  }
  if (!in.levels.in_contact()) return true;
  const FrictionModel& m = plant.friction;
  const double dwell = m.dwell_stiction.enabled ? 1.0 + m.dwell_stiction.gain : 1.0;
  const auto within = [&](double rate_state) {
    const double g_max = 4.0 * (std::max(in.levels.static_n * dwell, in.levels.coulomb_n) + in.levels.strengthening_n * 40.0 + rate_state) /
                         (modulation_floor(m) * m.lugre.sigma0_n_per_m);
    if (std::fabs(s.bristle_m) > g_max) return false;
    if (!m.presliding_hysteresis.enabled) return true;
    for (double z : s.slip_m) {
      if (!std::isfinite(z) || std::fabs(z) > 2.0 * g_max) return false;
    }
    return true;
  };
  // The rate-and-state addition at 1 m/s and an age of 1e6 s: a bound, not a
  // state. It is at least 0 and only widens the bound, so its log1p and log
  // are taken only for a tick that the bound without it refuses: the same
  // decision, faster.
  return within(0.0) || within(std::max(0.0, rate_state_n(m, in.levels, 1.0, 1e6)));
}

}  // namespace

double stribeck_at_tick_start(const LateralPlant& plant, const LateralInputs& in, LateralState& s,
                              const HeldContactMemory& memory) {
  const double last_q = memory.end_inverse_scale_per_m;
  return limit_to_static_friction(plant, in, s, last_q > 0 ? plant.friction.lugre.sigma0_n_per_m / last_q : 0.0);
}

AdvanceReport advance_lateral(const LateralPlant& plant, const LateralInputs& in,
                              const IntegratorSettings& settings, double dt_s, LateralState& s,
                              const double* stribeck_n_at_s, HeldContactMemory* memory) {
  const LateralState start = s;
  const bool held = settings.held_contact && held_contact_applies(plant);
  const LateralEvaluation now = held ? held_contact_start(plant, in, s, stribeck_n_at_s)
                                     : lateral_derivative(plant, in, s, stribeck_n_at_s);
  // Most ticks need one RK4 sub-step, and then plan_substeps takes RK4 whatever
  // the split rate (1 <= kSplitAdvantage x at least 1): the split rate (a log1p
  // and a log with rate-and-state) is estimated only when the plan needs it.
  LateralRates rates = lateral_rate_bounds(plant, in, s, now, dt_s, false, settings.max_h_lambda / dt_s);
  bool have_split = false;
  StepPlan plan;
  // wanted_substeps(...) == 1 exactly when the ratio is at most 1 (ceil(x) <= 1,
  // a NaN compares false): the same decision without the ceil.
  if (!(rates.full_per_s * dt_s / settings.max_h_lambda <= 1.0 && settings.max_substeps >= 1)) {
    rates = lateral_rate_bounds(plant, in, s, now, dt_s, true);
    have_split = true;
    plan = plan_substeps(rates, dt_s, settings.max_h_lambda, settings.max_substeps);
  }
  const SubstepScheme scheme = settings.midpoint ? SubstepScheme::kMidpoint : SubstepScheme::kRk4;
  int law_evaluations = 0;
  bool stopped;
  if (memory && (plan.split || !held)) *memory = {};  // the next held sub-step starts without an estimate
  if (plan.split) {
    stopped = integrate_lateral_split(plant, in, dt_s, plan.substeps, s, scheme);
  } else if (held) {
    stopped = integrate_lateral_held(plant, in, dt_s, plan.substeps, s, &now, settings.contact_law_tolerance_n, memory,
                                     &law_evaluations);
  } else {
    stopped = integrate_lateral(plant, in, dt_s, plan.substeps, s, &now.rate, scheme);
  }
  bool retried = false;
  if (!sane(plant, in, s)) {
    // The rate estimate was beaten (a violent transient): redo the tick with
    // the split scheme at four times the sub-steps the estimate asked for.
    s = start;
    retried = true;
    if (!have_split) rates = lateral_rate_bounds(plant, in, s, now, dt_s, true);
    const double n = 4.0 * std::max(wanted_substeps(rates.split_per_s, dt_s, settings.max_h_lambda),
                                    static_cast<double>(plan.substeps));
    plan = StepPlan{static_cast<int>(std::min<double>(n, settings.max_substeps)), true,
                    n > settings.max_substeps};
    stopped = integrate_lateral_split(plant, in, dt_s, plan.substeps, s, scheme);
    if (memory) *memory = {};
  }
  if (!plant.axis.backlash.enabled) {  // without backlash the tip is the plate
    s.tip_position_m = s.position_m;
    s.tip_velocity_m_per_s = s.velocity_m_per_s;
  }
  return AdvanceReport{plan.substeps, law_evaluations, plan.split, plan.capped, stopped, retried};
}

}  // namespace tribo::sim
