// Lateral (X) axis: the centre plate (mass m) on the transducer spring k and
// damping c, pulled by the drive (sim/electrostatic_drive.h) and held back by
// friction at the tip:
//
//   dx/dt = v
//   m dv/dt = F_drive(x) - k x - c v - F_friction(v_rel, z, ...) + F_tip
//   dz/dt   = LuGre bristle rate (sim/lugre_friction.h), at the tip's velocity
//             relative to the sample, v_rel = v - v_sample
//
// F_tip is the tilt's lateral share of the normal load (N tan theta, §5.2)
// and v_sample the sample's creep (drift, §3.3.3). Optional states: the
// contact age theta and lagged velocity v_L (sim/friction_effects.h), the
// Maxwell-slip elements (sim/maxwell_slip.h), and with backlash a separate
// tip (mass m_t, part of m) coupled to the plate through a dead zone of width
// 2b, stiffness k_b and damping c_b (acting only when engaged):
//
//   (m - m_t) dv/dt   = F_drive(x) - k x - c v - F_b
//   m_t dv_t/dt       = F_b - F_friction(v_t - v_sample, ...) + F_tip
//   F_b = k_b (d - b sgn d) + c_b (v - v_t)   for |d| > b,  0 otherwise,  d = x - x_t
//
// Stops: with the electrostatic drive the plate cannot pass stop_gap of a
// plate; arriving there it stops dead (snap-down) and stays while the net
// force holds it.
//
// The drive voltages, load and creep are held over a controller tick; the
// tick is integrated in n equal sub-steps, n chosen from the present state
// (sim/step_size.h), by one of two schemes:
//
// - integrate_lateral: classical RK4 on the whole state, whenever the
//   sub-steps resolve every rate of the plant, including the bristle
//   relaxation |v|/g(v).
// - integrate_lateral_split: at light loads g(v) ~ N -> 0 and the bristles
//   relax faster than any affordable step (|v|/g reaches 1e7 1/s on the first
//   tick of a loading ramp). For fixed v, dz/dt = v - a z with a = |v|/g(v) is
//   linear in z, so z is advanced exactly, z_ss + (z - z_ss) exp(-a h) with
//   z_ss = sgn(v) g(v), in a Strang splitting: half a step of the contact
//   states (z, Maxwell-slip elements, contact age, each exact for frozen v),
//   an RK4 step of the mechanical states with them frozen, half a step of the
//   contact states. Second order, and L-stable in the bristle modes: a
//   fast-relaxing bristle lands on its steady state.
#pragma once

#include "sim/electrostatic_drive.h"
#include "sim/friction_effects.h"
#include "sim/lugre_friction.h"
#include "sim/maxwell_slip.h"

namespace tribo::sim {

struct BacklashParams {
  bool enabled = false;
  double width_m = 0;  // total play 2b
  double tip_mass_kg = 0;
  double coupling_stiffness_n_per_m = 0;
  double coupling_damping_n_s_per_m = 0;
};

struct LateralAxisParams {
  double mass_kg = 0;  // everything that moves: plate and tip
  double spring_n_per_m = 0;
  double damping_n_s_per_m = 0;
  BacklashParams backlash;
};

struct LateralPlant {
  LateralAxisParams axis;
  FrictionModel friction;
};

struct LateralState {
  double position_m = 0;  // centre plate
  double velocity_m_per_s = 0;
  double tip_position_m = 0;  // with backlash only
  double tip_velocity_m_per_s = 0;
  double bristle_m = 0;  // LuGre z
  double lag_velocity_m_per_s = 0;
  double contact_age_s = 0;
  double rate_state_s = 0;  // phi of the rate-and-state law
  SlipElements slip_m{};  // Maxwell-slip z_i
};

// Time derivatives of a LateralState, field by field (position_m holds dx/dt,
// ...). The Maxwell-slip rates are set only for the elements in use.
struct LateralRate {
  double position_m = 0;
  double velocity_m_per_s = 0;
  double tip_position_m = 0;
  double tip_velocity_m_per_s = 0;
  double bristle_m = 0;
  double lag_velocity_m_per_s = 0;
  double contact_age_s = 0;
  double rate_state_s = 0;
  SlipElements slip_m;
};

// What is held over a tick.
struct LateralInputs {
  DriveField drive;
  FrictionLevels levels;
  double tip_force_n = 0;              // tilt: N tan(theta)
  double sample_velocity_m_per_s = 0;  // creep
  double sample_offset_m = 0;          // creep so far: tip position on the sample is x_t - offset
};

double tip_position_m(const LateralPlant& plant, const LateralState& s);
double tip_velocity_m_per_s(const LateralPlant& plant, const LateralState& s);

struct LateralEvaluation {
  LateralRate rate;
  double friction_n = 0;
  double deflection_scale_m = 0;  // g at the evaluated point (0 out of contact)
  double inverse_scale_per_m = 0; // 1/g (0 out of contact)
  double plasticity = 1;          // alpha of the single bristle (no Maxwell-slip elements)
};

// stribeck_n_at_s, if given, is stribeck_n at s's contact point for these
// inputs' levels, already computed (limit_to_static_friction returns it): the
// same value, not evaluated twice (for speed: each costs one to four
// transcendental functions).
LateralEvaluation lateral_derivative(const LateralPlant& plant, const LateralInputs& in,
                                     const LateralState& s, const double* stribeck_n_at_s = nullptr);

// The explicit scheme of one sub-step.
enum class SubstepScheme { kRk4, kMidpoint };

// Advances s by dt with n sub-steps (RK4 or midpoint). Returns true if the
// plate touched a stop. `first`, if given, is lateral_derivative at s (saves
// one evaluation).
bool integrate_lateral(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                       int substeps, LateralState& s, const LateralRate* first = nullptr,
                       SubstepScheme scheme = SubstepScheme::kRk4);

// integrate_lateral on every plant, without the specialised path
// (sim/compact_rk4.h) that integrate_lateral takes where it applies: for the
// tests that hold the two to the same bits.
bool integrate_lateral_general(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                               int substeps, LateralState& s, const LateralRate* first = nullptr,
                               SubstepScheme scheme = SubstepScheme::kRk4);

// A plate at a stop stays there while the net force presses it on: the
// rates of its position x are zeroed.
inline void hold_at_stop(const DriveField& f, double x_m, double& dx_dt, double& dv_dt) {
  if (!f.has_stops()) return;
  if ((x_m >= f.stop_positive_m() && dv_dt > 0) || (x_m <= f.stop_negative_m() && dv_dt < 0)) {
    dv_dt = 0;
    dx_dt = 0;
  }
}

// Keeps the plate within its stops; true if it is on one.
inline bool apply_stops(const DriveField& f, double& x_m, double& v_m_per_s) {
  if (!f.has_stops()) return false;
  if (x_m >= f.stop_positive_m()) {
    x_m = f.stop_positive_m();
    if (v_m_per_s > 0) v_m_per_s = 0;
    return true;
  }
  if (x_m <= f.stop_negative_m()) {
    x_m = f.stop_negative_m();
    if (v_m_per_s < 0) v_m_per_s = 0;
    return true;
  }
  return false;
}

// Advances s by dt with n split sub-steps (exact contact relaxation).
bool integrate_lateral_split(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                             int substeps, LateralState& s,
                             SubstepScheme scheme = SubstepScheme::kRk4);

// A stuck contact holds at most its static friction. LuGre alone keeps z at
// v = 0 whatever the load, so a contact unloaded under a held force kept it
// (627 uN at 1 mN of load, mu_s N = 143 uN) until contact was lost;
// here the bristle(s) slip back to what the present levels hold, once per
// tick when the levels are set. Steady sliding is untouched (z = g(v) within
// g(0)); besides unloading, the limit acts only where a modulation (position,
// contact age) lowers g faster than the bristle relaxes: an instant slip
// instead of one over the next few nm.
// Returns S (stribeck_n) at the contact point, which the limit leaves as it
// was (it moves only the bristles); 0 out of contact.
// guess_n: S of a nearby evaluation (the last sub-step's), where the solve of
// S with the slip rate starts (stribeck_n_at_deflection); 0: none.
double limit_to_static_friction(const LateralPlant& plant, const LateralInputs& in, LateralState& s,
                                double guess_n = 0);

// Stored energy: kinetic, spring, bristle (or elements), backlash coupling,
// and the potentials of the held drive field and tip force. With no sample
// creep it cannot grow while |z| <= g (LuGre's dissipativity; see tests).
double stored_energy_j(const LateralPlant& plant, const LateralInputs& in, const LateralState& s);

}  // namespace tribo::sim
