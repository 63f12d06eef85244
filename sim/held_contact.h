// The default sub-step scheme of the simulated instrument (integrator
// method INTEGRATION_RK4_HELD_CONTACT): classical RK4 on the fast states
// (plate position and velocity, bristle), with the contact law -- the
// Stribeck magnitude S with its rate-and-state and dwell terms, and the
// rates of the contact's slow states (sim/friction_effects.h:
// stribeck_n, contact_state_rates) -- evaluated at most twice a sub-step and
// held between:
//
//   law at the start s0:        S0 -> q0 = sigma0 / S0 (= 1/g), rates r0
//   Euler half step:            s_m = s0 + h/2 (k1, r0)
//   law at s_m:                 S_m -> q_m, rates r_m
//   RK4 stages on (x, v, z):    k1 at q0, k2 and k3 at q_m, k4 at 2 q_m - q0
//   slow states (theta, phi):   + h r_m                 (explicit midpoint)
//
// q is linear in time to second order over the sub-step (its RK4 weights
// average to q_m), so the law is integrated to second order and the plate
// and bristle, whose stiff mode sets the step (sim/step_size.h), to fourth.
// S is evaluated once a sub-step (at s0; q held at q0 throughout, the slow
// states still at their midpoint rates) where it does not matter or barely
// does: where the bristle cannot leave the elastic range of the
// elasto-plastic blend within the sub-step (|z| + 2 v_reach h <= r g:
// alpha = 0 at every stage, S does not enter the fast states' equations),
// and where holding it moves the friction by at most a tolerance
// (integrate_lateral_held). S is evaluated at every sub-step's start: held
// over a whole sub-step it misses the loop's noise, which moves the slip
// rate, and with it S, from tick to tick. The drive's attraction is linear
// in x over the sub-step where its curvature term is below 1e-9 N. The law's formulas
// live in sim/friction_effects.cc; this file only decides where they are
// evaluated. With the direct effect on the slip rate an evaluation of S
// solves S with the slip rate at that point's bristle deflection
// (stribeck_n_at_deflection), so the held S is consistent with z there.
//
// Serves the plants without backlash, Maxwell-slip elements or frictional
// lag (every named config); the others are integrated with the law at every
// RK4 stage (integrate_lateral).
#pragma once

#include "sim/lateral_plant.h"

namespace tribo::sim {

bool held_contact_applies(const LateralPlant& plant);

// lateral_derivative at s for such a plant, by the sub-steps' own
// evaluation (S at s given, if stribeck_n_at_s).
LateralEvaluation held_contact_start(const LateralPlant& plant, const LateralInputs& in, const LateralState& s,
                                     const double* stribeck_n_at_s);

// What the scheme remembers from one sub-step to the next (across ticks):
// 1/g at the last evaluation of S at a sub-step's start (0: none, as after
// contact is made) and Fc there (1/g is compared at the same load-normalised
// value: S scales with the levels at a given slip rate), the time since (to
// the last sub-step's end), the rate 1/g changed at between the last two
// such evaluations (< 0: not known), and 1/g extrapolated to the last
// sub-step's end (where the next evaluation of S starts its solve, with the
// direct effect on the slip rate).
struct HeldContactMemory {
  double inverse_scale_per_m = 0;
  double coulomb_n = 0;
  double held_s = 0;
  double change_per_s = -1;
  double end_inverse_scale_per_m = 0;
};

// Advances s by dt_s in `substeps` equal sub-steps; true if the plate touched
// a stop. `first`, if given, is lateral_derivative at s (the first sub-step's
// law at its start). With a memory
// and a tolerance > 0, S is also held at its start value (one evaluation)
// where the friction force that holding it can move within the sub-step,
// sigma1 (alpha + |u| dalpha/du) |v| |z| |dq/dt| h / 2 (u = z / g; the blend's
// slope counts: the slip alpha |v| u moves with u through alpha too) with
// dq/dt the rate 1/g changed at between the last two evaluations at
// sub-steps' starts, is at most tolerance_n. law_evaluations, if given, is
// increased by the number of
// evaluations of S made (for tests and benchmarks).
bool integrate_lateral_held(const LateralPlant& plant, const LateralInputs& in, double dt_s, int substeps,
                            LateralState& s, const LateralEvaluation* first, double tolerance_n = 0,
                            HeldContactMemory* memory = nullptr, int* law_evaluations = nullptr);

}  // namespace tribo::sim
