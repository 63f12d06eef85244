// A discrete PID with set-point weights, a filtered derivative and output
// limits, stepped with the nominal loop period.
//
//   P = kp (b r - y)
//   I += ki dt (r - y)                 (integration on the error, so no offset)
//   D = kd d/dt (c r - y), low-passed: Tf dD/dt + D = kd d/dt(c r - y),
//       Tf = 1 / (2 pi derivative_filter_hz), discretised by backward Euler
//   u = clamp(P + I + D, output_min, output_max)
//
// b = c = 0 gives the I-PD loop of the dissertation (§5.4): proportional and
// derivative act on the measurement only, so setpoint ramps do not kick.
// Anti-windup (this version): conditional integration -- the integrator holds
// while the output is saturated and the error would drive it further in.
// Reset: pid_reset() makes the next output continue from `output` with no
// derivative kick (bumpless).
#pragma once

namespace tribo::daemon {

struct PidGains {
  double kp = 0;
  double ki = 0;
  double kd = 0;
  double setpoint_weight_p = 0;  // b
  double setpoint_weight_d = 0;  // c
  double derivative_filter_hz = 0;  // 0: unfiltered
  double output_min = 0;
  double output_max = 0;
};

struct PidState {
  double integral = 0;
  double derivative = 0;
  double previous_d_input = 0;  // c r - y at the previous step
  bool saturated = false;       // the last output was clamped
};

// Resets for a bumpless start: the output continues from `output`.
void pid_reset(const PidGains& g, double setpoint, double measurement, double output, PidState& s);

double pid_update(const PidGains& g, double setpoint, double measurement, double dt_s,
                  PidState& s);

}  // namespace tribo::daemon
