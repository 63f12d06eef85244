// How a controller tick is integrated: how many sub-steps, and by which scheme
// (sim/lateral_plant.h). The plant is stiff (with the Appendix C numbers its
// fastest mode in stick is ~5e3 1/s, and the bristle relaxation |v|/g reaches
// 1e7 1/s at light loads), so the sub-step h follows from an estimate lambda
// of the magnitude of the plant's fastest eigenvalue at the present state:
// h * lambda <= max_h_lambda.
//
// Linearised about the present state the bristle follows the tip with
// dz ~ d dx, d = d(dz/dt)/dv, so the mechanical mode of the mass m_f that
// friction acts on (the tip's with backlash, else the whole moving mass) is
// the root of lambda^2 + B lambda + K with
//
//   B = (c_f + sigma2 + sigma1 d) / m_f,   K = (k - k_e + sigma0 d) / m_f
//   |lambda_mech| = B/2 + sqrt(B^2/4 - K)   (real roots; sqrt(K) when complex)
//
// (k_e the drive's negative stiffness; with backlash the plate's mode, with
// k_b and c_b, is added). d = |1 - alpha sgn(v) z/g| + (|z|/g) |v| g'(v)/g at
// the present state, or its bound 1 + (|z|/g)(1 + ...) if the velocity may
// reverse within the tick (|v| <= |dv/dt| dt). |v| g'(v)/g = |v| S'(v)/S is
// bounded by ((Fs D - Fc)/e + Fvs + a N) over the smaller of Fc and half the
// present S (no effect halves S within a tick), never below S's floor. Where
// the bristle stays within the elasto-plastic blend's elastic range over the
// whole tick (alpha = 0, |z| + 2 v_reach dt <= r g), dz/dt = v: d = 1 exactly
// and the bristle has no relaxation. To that are added the contact's own
// rates:
//
//   v_reach / g * P                  bristle relaxation |v|/g (P = 1 + the largest
//                                    slope g dalpha/dz of the elasto-plastic blend,
//                                    at most pi/(2(1-r)), over the |z|/g the tick
//                                    can reach; 1 for plain LuGre)
//   (v_reach + V*) / D_c (|ln x| + 1)  rate-and-state state (slip law; 1 for ageing;
//                                    |ln x| bounded from x's binary exponent)
//   v_reach (|z|/g) |dg/dx| / g      position-periodic friction
//   v_reach / D_c                    contact ageing (dwell)
//   1 / tau_L                        frictional lag
//
// with v_reach = |v_rel| + |dv/dt| dt, the speed reachable within the tick.
// With Maxwell-slip elements g is the smallest element's scale and d takes
// its bound. The estimate is exact for the stuck contact (where it matters)
// and within a factor ~2 elsewhere; RK4 is stable for h lambda up to 2.78 on
// the negative real axis, so max_h_lambda = 1 keeps the stiff modes accurate
// as well as stable (measured: tests/sim/integrator_accuracy_test.cc); the
// held-contact scheme (sim/held_contact.h), whose slow states take the
// explicit midpoint rule (stable to 2), runs the default at 1.5
// (tests/sim/fine_step_reference_test.cc).
//
// If that many RK4 sub-steps fit under max_substeps, and are not more than
// kSplitAdvantage times what the split scheme needs, the tick uses plain RK4.
// Otherwise the contact relaxation is what cannot be resolved (light loads,
// fast arrivals), and the tick uses the split scheme, whose contact step is
// exact: its estimate drops the relaxation and ageing terms and takes d at
// its bound. A safety net: a tick whose result is not finite, or whose
// bristles end far beyond any possible deflection, is redone with the split
// scheme at four times the sub-steps (reported as `retried`).
#pragma once

#include "sim/held_contact.h"
#include "sim/lateral_plant.h"

namespace tribo::sim {

struct LateralRates {
  double full_per_s = 0;   // all modes, for plain RK4
  double split_per_s = 0;  // without the contact relaxation, for the split scheme
};

// `now` is lateral_derivative(plant, in, s).
LateralRates lateral_rate_bounds(const LateralPlant& plant, const LateralInputs& in,
                                 const LateralState& s, const LateralEvaluation& now, double dt_s);
// The same; without with_split, split_per_s is left 0 (not estimated). A
// full_per_s at or below enough_per_s may be the coarser estimate (the
// elasto-plastic blend's steepest slope instead of the slope within reach).
LateralRates lateral_rate_bounds(const LateralPlant& plant, const LateralInputs& in,
                                 const LateralState& s, const LateralEvaluation& now, double dt_s,
                                 bool with_split, double enough_per_s = 0);

// The split scheme is preferred once RK4 would need this many times its sub-steps.
inline constexpr double kSplitAdvantage = 8.0;

struct StepPlan {
  int substeps = 1;
  bool split = false;   // use integrate_lateral_split
  bool capped = false;  // even the split scheme wanted more than max_substeps
};

StepPlan plan_substeps(const LateralRates& rates, double dt_s, double max_h_lambda,
                       int max_substeps);

struct IntegratorSettings {
  double max_h_lambda = 1.0;
  int max_substeps = 1000;
  bool midpoint = false;  // coarse mode: the explicit midpoint rule instead of RK4
  // RK4 with the contact law held over each sub-step (sim/held_contact.h)
  // where the plant allows; otherwise the law at every stage.
  bool held_contact = false;
  // Held contact: the friction force holding S at a sub-step's start may
  // move, at most (0: S also evaluated at every sub-step's midpoint).
  double contact_law_tolerance_n = 0;
};

struct AdvanceReport {
  int substeps = 0;
  int law_evaluations = 0;  // of S, by the held-contact scheme (0 from the others)
  bool split = false;
  bool capped = false;
  bool stopped = false;  // the plate touched a stop
  bool retried = false;  // the first attempt was not sane; the tick was redone (split, 4x sub-steps)
};

// S at a tick's start, the bristle limited by it:
// limit_to_static_friction, its solve of S with the slip rate starting from
// memory's 1/g at the last sub-step's end.
double stribeck_at_tick_start(const LateralPlant& plant, const LateralInputs& in, LateralState& s,
                              const HeldContactMemory& memory);

// Integrates the plant over dt_s under held inputs: estimates the rates,
// plans the sub-steps and the scheme, and runs them.
// stribeck_n_at_s: as for lateral_derivative (S at s, already computed).
// memory: the held-contact scheme's, carried from tick to tick (or none).
AdvanceReport advance_lateral(const LateralPlant& plant, const LateralInputs& in,
                              const IntegratorSettings& settings, double dt_s, LateralState& s,
                              const double* stribeck_n_at_s = nullptr, HeldContactMemory* memory = nullptr);

}  // namespace tribo::sim
