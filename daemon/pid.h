// A discrete PID with set-point weights, a filtered derivative, output limits,
// anti-windup, feed-forward, bumpless gain changes and explicit resets,
// stepped with the nominal loop period dt. At step k, with setpoint r,
// measurement y and feed-forward input f:
//
//   e  = r - y
//   P  = kp (b r - y)                          b = setpoint_weight_p
//   D  = (Tf D' + kd (d - d')) / (Tf + dt)     d = c r - y, c = setpoint_weight_d;
//                                              D', d' from step k-1. Backward Euler
//                                              of Tf dD/dt + D = kd dd/dt with
//                                              Tf = 1 / (2 pi derivative_filter_hz)
//                                              (Tf = 0: the plain difference).
//   I* = I' + ki dt e                          integration of the error (no offset)
//   v  = P + I* + D + feedforward_gain f + a   unclamped output; a: a term added
//                                              outside the gains (the friction
//                                              compensation, daemon/controller.h)
//   u  = clamp(v, output_min, output_max)      the output
//
// and the stored integral I depends on the anti-windup:
//
//   ANTI_WINDUP_NONE          I = I*. Saturation lets I grow without bound
//                             (windup): the output overshoots once the error
//                             reverses. For tests and comparisons.
//   CONDITIONAL_INTEGRATION   I = I* unless the output is saturated and the
//                             error drives it further in (v > max and e > 0,
//                             or v < min and e < 0); then I = I'.
//   BACK_CALCULATION          I = I* + (dt / Tt) (u - v): while saturated the
//                             integrator is pulled back towards the limit with
//                             time constant Tt = tracking_time_s (0 picks
//                             sqrt(Ti Td) with Ti = kp/ki, Td = kd/kp when
//                             kd > 0, else Ti; one period without kp or ki).
//                             dt/Tt is capped at 1 (exact tracking).
//
// b = c = 0 gives the I-PD loop of the dissertation (§5.4): proportional and
// derivative act on the measurement only, so setpoint ramps do not kick.
//
// Reset semantics (pid_reset): the derivative state is cleared, d' is set to
// the present c r - y (no derivative kick on the next step) and the integral
// is set so that, with the same r, y, f and a, the unclamped output is exactly
// `output` (plus the next step's ki dt e). pid_reset(..., 0, ...) is the
// classic reset to zero; resetting to the present drive is bumpless.
//
// Gain changes (pid_change_gains): D is rescaled by kd_new / kd_old (cleared
// when kd_old = 0) and I is recomputed so that the new gains, at the last r,
// y and f, give the last applied output u: the output continues without a
// step, and the new gains act from the next error on.
//
// Invalid input: when dt is not positive and finite, or r, y or f is not
// finite, the state is left untouched and the last output is returned (the
// drive holds); input_invalid tells the caller.
#pragma once

namespace tribo::daemon {

enum class AntiWindup { kNone, kConditionalIntegration, kBackCalculation };

struct PidGains {
  double kp = 0;
  double ki = 0;
  double kd = 0;
  double setpoint_weight_p = 0;     // b
  double setpoint_weight_d = 0;     // c
  double derivative_filter_hz = 0;  // 0: unfiltered
  double output_min = 0;
  double output_max = 0;
  AntiWindup anti_windup = AntiWindup::kConditionalIntegration;
  double tracking_time_s = 0;       // BACK_CALCULATION; 0: derived (above)
  double feedforward_gain = 0;
};

struct PidState {
  double integral = 0;
  double derivative = 0;
  double previous_d_input = 0;  // c r - y at the previous step
  double output = 0;            // the last output u
  double setpoint = 0;          // the last valid inputs
  double measurement = 0;
  double feedforward = 0;
  double added = 0;             // the last added term a
  bool saturated = false;       // the last output was clamped
  bool input_invalid = false;   // the last call held the output (invalid input)
};

// The tracking time that BACK_CALCULATION uses for these gains.
double pid_tracking_time_s(const PidGains& g, double dt_s);

// Resets so that the output continues from `output` (see above).
void pid_reset(const PidGains& g, double setpoint, double measurement, double feedforward,
               double output, PidState& s, double added = 0);

double pid_update(const PidGains& g, double setpoint, double measurement, double feedforward,
                  double dt_s, PidState& s);

// The terms of an update that depend only on the gains and the period,
// computed by the operations pid_update uses for them: a caller that steps
// the same gains every tick computes them once per gain change (the
// controller; issue 17: two divisions a tick fewer) and gets the same outputs.
struct PidTerms {
  double filter_time_s = 0;  // 1 / (2 pi derivative_filter_hz), 0 unfiltered
  double ki_dt = 0;          // ki dt
  double tracking_gain = 0;  // BACK_CALCULATION: min(1, dt / tracking time)
};
PidTerms pid_terms(const PidGains& g, double dt_s);

// pid_update with the terms of pid_terms(g, dt_s), and a term `added` to the
// output before the clamp (a non-finite one is invalid input).
double pid_update(const PidGains& g, const PidTerms& terms, double setpoint, double measurement,
                  double feedforward, double dt_s, PidState& s, double added = 0);

// Moves the term added to the output from `from` to `to` without a step in
// the output: the integral takes the difference (a compensation switched on
// or off hands its share to the integrator, or takes it over).
void pid_shift_added(double from, double to, PidState& s);

// Switches from old_gains to new_gains without a step in the output.
void pid_change_gains(const PidGains& old_gains, const PidGains& new_gains, PidState& s);

}  // namespace tribo::daemon
