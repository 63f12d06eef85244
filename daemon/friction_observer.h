// The friction observer of the compensation: the identified model
// (daemon/identified_friction.h) run on line beside the loop, in the form of
// the observer of Canudas de Wit, Olsson, Astrom and Lischinsky (1995, IEEE
// Trans. Autom. Control 40(3), 419-425, sec. V):
//
//   dz^/dt = v - alpha |v| z^ / g(v) - k e        e = x - x_r, the position error
//   F^     = sigma0 z^ + sigma1 dz^/dt + Fv v + N tan(theta_tilt)
//
// v is the commanded velocity (COMMANDED, the default; the controller may
// delay and lag it, controller.friction_compensation.velocity_delay_s and
// velocity_lag_s) or the tip's velocity
// estimated from the loop's position reading (MEASURED: a first-order
// low-pass of its differences at velocity_filter_hz); k the observer gain of
// their correction term (k = 0: the model alone); N the measured load. The
// contact age of dwell stiction and the rate-and-state variable follow their
// evolution laws at |v|, or at |v^| (contact_state_from_measured: a contact
// keeps its memory while the tip, lagging the command, has not slid it). On the default instrument a MEASURED observer feeds
// the contact's own stiffness back (sigma0 z^ follows the measured presliding
// displacement) and drives the loop into stick-slip; the COMMANDED one is a
// feed-forward along the motion the loop is asked for, its state corrected
// by the position error (docs/friction_compensation.md has the figures).
//
// Each tick is integrated exactly at the tick's velocity (the bristle relaxes
// exponentially towards its steady state, as tribo-fit integrates the model
// between samples), so a stiff contact or a slow loop (10 Hz) needs no
// sub-steps. z^ stays within the static deflection Fs'/sigma0 at the present
// load: F^ is bounded by the model's static friction whatever the correction
// does. That bound is a projection of the state, not a motion of the bristle:
// dz^/dt in the damping term is the bristle's motion within the tick's bound.
// Fixed work per tick, no allocation, no I/O.
#pragma once

#include "daemon/identified_friction.h"

namespace tribo::daemon {

enum class ObserverVelocity { kCommanded, kMeasured };

struct ObserverSettings {
  double observer_gain_per_s = 0;   // k
  double velocity_filter_hz = 0;    // 0: the plain difference of the readings
  ObserverVelocity velocity = ObserverVelocity::kCommanded;
  // The rate-and-state variable and the contact age evolve at the speed
  // estimated from the position reading (v^), whatever drives the rest.
  bool contact_state_from_measured = false;
};

struct ObserverState {
  bool primed = false;         // a first position was seen
  double position_m = 0;       // the last finite reading
  double velocity_m_per_s = 0; // v^
  double bristle_m = 0;        // z^
  double rate_state_s = 0;     // theta (rate_state)
  double contact_age_s = 0;    // dwell_stiction
  double driving_velocity_m_per_s = 0;  // the v of the last step
};

struct ObserverInput {
  double position_m = 0;       // the loop's reading
  double position_error_m = 0; // x - x_r (0 where no position is commanded)
  double normal_force_n = 0;   // the measured load (load-scaled models)
  double commanded_velocity_m_per_s = 0;
  double period_s = 0;
};

struct ObserverOutput {
  double force_n = 0;          // F^: the friction and the tilt's push the drive must supply
  double friction_n = 0;       // its friction part
  bool advanced = false;       // false: an input was not finite (the state was not advanced)
};

// The initial state of a contact at rest (no age, the slip law's theta at
// Dc / v_ref).
ObserverState observer_at_rest(const IdentifiedFriction& model);

// Advances the state by one period and returns the compensation force.
ObserverOutput observer_step(const IdentifiedFriction& model, const ObserverSettings& settings,
                             const ObserverInput& in, ObserverState& state);

// S(v) of the model at this speed, load, state and direction (tests, docs).
double identified_friction_level(const IdentifiedFriction& model, double speed_m_per_s, double direction,
                                 double normal_force_n, double rate_state_s, double contact_age_s);

// The most S can reach at speeds up to max_speed, loads up to max_load and
// within elapsed_s of a contact at rest (observer_at_rest): the static level
// with dwell at its full gain, the log-velocity terms at whichever end of the
// speed range raises them, the rate-and-state variable at whichever end of
// its range over that time raises its term (theta grows by at most 1 per
// second with the ageing law, 1/e with the slip law), the load dependence at the highest load, the stronger
// direction (the protocol validator's bound).
double identified_friction_bound(const IdentifiedFriction& model, double max_speed_m_per_s, double max_load_n,
                                 double elapsed_s);

}  // namespace tribo::daemon
