#include "sim/held_contact.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tribo::sim {

namespace {

// The fast states and their rates.
struct Fast {
  double x = 0, v = 0, z = 0;
};

Fast add_scaled(const Fast& s, const Fast& r, double h) { return Fast{s.x + h * r.x, s.v + h * r.v, s.z + h * r.z}; }

struct Slow {
  double age = 0, phi = 0;
};

// The drive's force over a sub-step from x0: the plates' attraction is
// smooth on the scale of the gaps (100 um and more) while a sub-step moves
// the plate by nanometres, so it is taken as F(x0) + k_e (x - x0) with the
// field's own k_e = dF/dx, where the quadratic term it leaves out,
// F''/2 dx^2 = 3/2 (k_e / gap) dx^2, is below kLinearDriveError over the
// sub-step's reach; elsewhere (near a stop, or the plate moving fast) the
// field itself, with its stops.
constexpr double kLinearDriveError_n = 1e-9;

struct DriveOverSubstep {
  bool linear = false;
  double x0 = 0, force0_n = 0, stiffness_n_per_m = 0;
};

DriveOverSubstep linearise_drive(const DriveField& f, double x0, double reach_m) {
  DriveOverSubstep d;
  d.x0 = x0;
  if (!f.has_stops()) {  // the ideal actuator: a constant force
    d.linear = true;
    d.force0_n = f.constant_n;
    return d;
  }
  const double gap_pos = f.gap_positive_m - x0, gap_neg = f.gap_negative_m + x0;
  if (!(gap_pos > 2 * f.stop_gap_m && gap_neg > 2 * f.stop_gap_m)) return d;
  const double inv_pos = 1.0 / gap_pos, inv_neg = 1.0 / gap_neg;
  const double pull_pos = f.coeff_positive * inv_pos * inv_pos, pull_neg = f.coeff_negative * inv_neg * inv_neg;
  d.force0_n = f.constant_n + pull_pos - pull_neg;
  d.stiffness_n_per_m = 2.0 * (pull_pos * inv_pos + pull_neg * inv_neg);
  // F'' = 6 (c+ / gap+^4 - c- / gap-^4), bounded by the sum of magnitudes.
  const double curvature = 6.0 * (pull_pos * inv_pos * inv_pos + pull_neg * inv_neg * inv_neg);
  d.linear = 0.5 * curvature * reach_m * reach_m <= kLinearDriveError_n;
  return d;
}

// d(alpha u)/du at u = z / g: how much the bristle's slip alpha |v| u moves
// per unit change of u, and so of 1/g. In the elasto-plastic blend alpha
// itself rises with u, by dalpha/du = pi / (1 - r) sqrt(alpha (1 - alpha))
// (alpha = (1 + sin theta) / 2: cos theta = 2 sqrt(alpha (1 - alpha))), up to
// pi / (2 (1 - r)): 19 at r = 0.917, 110 at r = 0.986, where alpha alone
// would understate the change that holding S makes.
double slip_sensitivity(const LugreParams& p, double alpha, double u) {
  const double r = p.breakaway_ratio;
  if (!(r > 0) || !(alpha > 0 && alpha < 1)) return alpha;
  return alpha + std::fabs(u) * std::numbers::pi / (1 - r) * std::sqrt(alpha * (1 - alpha));
}

// The friction force that holding 1/g at q moves on average over a sub-step
// of h, 1/g changing at change_per_s: the slip alpha |v| u (u = z q) moves by
// |v| (alpha + |u| dalpha/du) |z| dq, times sigma1.
double held_friction_change_n(const LugreParams& p, double alpha, double v, double z, double q, double change_per_s,
                              double h) {
  return p.sigma1_n_s_per_m * slip_sensitivity(p, alpha, z * q) * std::fabs(v) * std::fabs(z) * change_per_s * 0.5 * h;
}

// 1/g remembered, at the present levels: S scales with them at a given
// slip-rate logarithm (contact_levels scales Fs, Fc, Fvs and N_rs together
// with the load), so 1/g is taken at the same load-normalised value.
double remembered_inverse_scale(const LateralInputs& in, const HeldContactMemory& memory) {
  return memory.inverse_scale_per_m * (memory.coulomb_n / in.levels.coulomb_n);
}

class HeldContactStep {
 public:
  HeldContactStep(const LateralPlant& plant, const LateralInputs& in)
      : plant_(plant), in_(in), m_(plant.friction), contact_(in.levels.in_contact()),
        inverse_mass_per_kg_(1.0 / plant.axis.mass_kg) {}

  bool in_contact() const { return contact_; }

  // The drive over the sub-step that starts at s (k1 its rates there).
  void hold_drive(const Fast& s, const Fast& k1, double h) {
    drive_ = linearise_drive(in_.drive, s.x, 2.0 * (std::fabs(s.v) + std::fabs(k1.v) * h) * h);
  }

  ContactPoint point(const Fast& f, const Slow& slow) const {
    const double v = f.v - in_.sample_velocity_m_per_s;
    return ContactPoint{v, v, f.x - in_.sample_offset_m, slow.age, slow.phi};
  }

  // 1/g at the point with the bristle at z: one evaluation of S (with the
  // direct effect on the slip rate, S solved with it from a nearby point's
  // 1/g, guess_q, if > 0: stribeck_n_at_deflection).
  double inverse_scale(ContactPoint c, double z, double guess_q) const {
    const double sigma0 = m_.lugre.sigma0_n_per_m;
    return sigma0 / stribeck_n_at_deflection(m_, in_.levels, c, z, guess_q > 0 ? sigma0 / guess_q : 0.0);
  }

  struct Rate {
    Fast fast;
    double friction_n = 0;
    double plasticity = 1;
  };

  // dx/dt, dv/dt, dz/dt at 1/g = q (the law held), and the friction.
  Rate rate_with_friction(const Fast& s, double q) const {
    const LateralAxisParams& axis = plant_.axis;
    Rate r;
    double dz = 0;
    if (contact_) {
      const LugreOutput out = lugre_bristle_at_inverse_scale(m_.lugre, q, s.v - in_.sample_velocity_m_per_s, s.z);
      r.friction_n = out.force_n;
      r.plasticity = out.plasticity;
      dz = out.dz_dt_m_per_s;
    }
    const double drive_n =
        drive_.linear ? drive_.force0_n + drive_.stiffness_n_per_m * (s.x - drive_.x0) : in_.drive.force_n(s.x);
    const double plate_n = drive_n - axis.spring_n_per_m * s.x - axis.damping_n_s_per_m * s.v;
    r.fast = Fast{s.v, (plate_n - r.friction_n + in_.tip_force_n) * inverse_mass_per_kg_, dz};
    if (!drive_.linear) hold_at_stop(in_.drive, s.x, r.fast.x, r.fast.v);
    return r;
  }

  Fast rate(const Fast& s, double q) const { return rate_with_friction(s, q).fast; }

  // The slow states' rates at the point, the bristle moving at dz/dt.
  Slow slow_rate(const ContactPoint& c, double dz_dt) const {
    if (!contact_) return {};
    const ContactStateRates r = contact_state_rates(m_, c, c.velocity_m_per_s - dz_dt);
    return Slow{r.contact_age, r.rate_state};
  }

  // S does not enter the sub-step: the bristle stays within the elastic
  // range r g of the elasto-plastic blend at every stage (alpha = 0), with a
  // factor 2 on the reach of the stages' speeds.
  bool stays_elastic(const Fast& s, const Fast& k1, double q, double h) const {
    const double r = m_.lugre.breakaway_ratio;
    if (!contact_ || !(r > 0)) return false;
    const double v_reach = std::fabs(s.v - in_.sample_velocity_m_per_s) + std::fabs(k1.v) * h;
    return (std::fabs(s.z) + 2.0 * v_reach * h) * q <= r;
  }

 private:
  const LateralPlant& plant_;
  const LateralInputs& in_;
  const FrictionModel& m_;
  bool contact_;
  double inverse_mass_per_kg_;  // a multiplication at each stage, not a division on its dependency chain
  DriveOverSubstep drive_;  // not linear: the field itself (the tick's first evaluation)
};

}  // namespace

LateralEvaluation held_contact_start(const LateralPlant& plant, const LateralInputs& in, const LateralState& state,
                                     const double* stribeck_n_at_s) {
  const HeldContactStep step(plant, in);
  const Fast s{state.position_m, state.velocity_m_per_s, state.bristle_m};
  const ContactPoint c = step.point(s, Slow{state.contact_age_s, state.rate_state_s});
  LateralEvaluation e;
  if (step.in_contact()) {
    ContactPoint at = c;
    const double stribeck =
        stribeck_n_at_s ? *stribeck_n_at_s : stribeck_n_at_deflection(plant.friction, in.levels, at, s.z);
    e.inverse_scale_per_m = plant.friction.lugre.sigma0_n_per_m / stribeck;
    e.deflection_scale_m = stribeck / plant.friction.lugre.sigma0_n_per_m;
  }
  const HeldContactStep::Rate r = step.rate_with_friction(s, e.inverse_scale_per_m);
  e.rate.position_m = r.fast.x;
  e.rate.velocity_m_per_s = r.fast.v;
  e.rate.bristle_m = r.fast.z;
  const Slow slow = step.slow_rate(c, r.fast.z);
  e.rate.contact_age_s = slow.age;
  e.rate.rate_state_s = slow.phi;
  e.friction_n = r.friction_n;
  e.plasticity = r.plasticity;
  return e;
}

bool held_contact_applies(const LateralPlant& plant) {
  const FrictionModel& m = plant.friction;
  return !plant.axis.backlash.enabled && !m.presliding_hysteresis.enabled && !m.frictional_lag.enabled;
}

bool integrate_lateral_held(const LateralPlant& plant, const LateralInputs& in, double dt_s, int substeps,
                            LateralState& state, const LateralEvaluation* first, double tolerance_n,
                            HeldContactMemory* memory, int* law_evaluations) {
  HeldContactStep step(plant, in);
  const bool contact = step.in_contact();
  const double h = dt_s / substeps;
  Fast s{state.position_m, state.velocity_m_per_s, state.bristle_m};
  Slow slow{state.contact_age_s, state.rate_state_s};
  int evaluations = 0;
  bool stopped = false;
  double q_guess = memory ? memory->end_inverse_scale_per_m : 0.0;  // 1/g at the last sub-step's end
  for (int i = 0; i < substeps; ++i) {
    // The law at the sub-step's start.
    double q0 = 0, alpha0 = 1;
    Fast k1;
    Slow r0;
    if (i == 0 && first) {
      q0 = first->inverse_scale_per_m;
      alpha0 = first->plasticity;
      evaluations += contact;  // the caller's evaluation of S at s
      k1 = Fast{first->rate.position_m, first->rate.velocity_m_per_s, first->rate.bristle_m};
      r0 = Slow{first->rate.contact_age_s, first->rate.rate_state_s};
    } else {
      const ContactPoint c = step.point(s, slow);
      if (contact) {
        q0 = step.inverse_scale(c, s.z, q_guess);
        ++evaluations;
      }
      const HeldContactStep::Rate rate = step.rate_with_friction(s, q0);
      k1 = rate.fast;
      alpha0 = rate.plasticity;
      r0 = step.slow_rate(c, k1.z);
    }
    if (memory) {
      if (!contact) {
        *memory = {};
      } else {  // the rate 1/g changed at since the last evaluation
        memory->change_per_s = memory->inverse_scale_per_m > 0 && memory->held_s > 0
                                   ? std::fabs(q0 - remembered_inverse_scale(in, *memory)) / memory->held_s
                                   : -1.0;
        memory->inverse_scale_per_m = q0;
        memory->coulomb_n = in.levels.coulomb_n;
        memory->held_s = 0;
      }
    }
    // S held over the sub-step where holding it cannot move the friction by
    // more than the tolerance (its rate of change between the last two
    // evaluations as the estimate of its change over this one).
    bool hold = !contact || step.stays_elastic(s, k1, q0, h);
    if (!hold && memory && memory->change_per_s >= 0 && tolerance_n > 0) {
      hold = held_friction_change_n(plant.friction.lugre, alpha0, s.v - in.sample_velocity_m_per_s, s.z, q0,
                                    memory->change_per_s, h) <= tolerance_n;
    }
    step.hold_drive(s, k1, h);
    // The law at the Euler half step (S only where it is not held).
    const Fast mid = add_scaled(s, k1, h / 2);
    const Slow slow_mid{slow.age + h / 2 * r0.age, slow.phi + h / 2 * r0.phi};
    const ContactPoint c_mid = step.point(mid, slow_mid);
    double q_mid = q0;
    if (!hold) {
      q_mid = step.inverse_scale(c_mid, mid.z, q0);
      ++evaluations;
    }
    const Fast k2 = step.rate(mid, q_mid);
    const Slow r_mid = step.slow_rate(c_mid, k2.z);
    const Fast k3 = step.rate(add_scaled(s, k2, h / 2), q_mid);
    // 1/g at the end, extrapolated linearly (bounded to a factor 2 of q_mid).
    const double q_end = std::clamp(2.0 * q_mid - q0, 0.5 * q_mid, 2.0 * q_mid);
    q_guess = q_end;
    if (memory && contact) {
      memory->held_s += h;
      memory->end_inverse_scale_per_m = q_end;
    }
    const Fast k4 = step.rate(add_scaled(s, k3, h), q_end);
    s = Fast{s.x + h / 6 * (k1.x + 2.0 * (k2.x + k3.x) + k4.x), s.v + h / 6 * (k1.v + 2.0 * (k2.v + k3.v) + k4.v),
             s.z + h / 6 * (k1.z + 2.0 * (k2.z + k3.z) + k4.z)};
    slow = Slow{slow.age + h * r_mid.age, slow.phi + h * r_mid.phi};
    stopped |= apply_stops(in.drive, s.x, s.v);
  }
  state.position_m = s.x;
  state.velocity_m_per_s = s.v;
  state.bristle_m = s.z;
  state.contact_age_s = slow.age;
  state.rate_state_s = slow.phi;
  if (law_evaluations) *law_evaluations += evaluations;
  return stopped;
}

}  // namespace tribo::sim
