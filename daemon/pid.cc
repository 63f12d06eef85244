#include "daemon/pid.h"

#include <algorithm>
#include <numbers>

namespace tribo::daemon {

void pid_reset(const PidGains& g, double setpoint, double measurement, double output,
               PidState& s) {
  s.derivative = 0;
  s.previous_d_input = g.setpoint_weight_d * setpoint - measurement;
  s.integral = output - g.kp * (g.setpoint_weight_p * setpoint - measurement);
  s.saturated = false;
}

double pid_update(const PidGains& g, double setpoint, double measurement, double dt_s,
                  PidState& s) {
  const double error = setpoint - measurement;
  const double p = g.kp * (g.setpoint_weight_p * setpoint - measurement);

  const double d_input = g.setpoint_weight_d * setpoint - measurement;
  const double tf = g.derivative_filter_hz > 0 ? 1.0 / (2.0 * std::numbers::pi * g.derivative_filter_hz) : 0.0;
  s.derivative = (tf * s.derivative + g.kd * (d_input - s.previous_d_input)) / (tf + dt_s);
  s.previous_d_input = d_input;

  const double candidate_integral = s.integral + g.ki * dt_s * error;
  const double unclamped = p + candidate_integral + s.derivative;
  const double output = std::clamp(unclamped, g.output_min, g.output_max);
  const bool winding_up = (unclamped > g.output_max && error > 0) ||
                          (unclamped < g.output_min && error < 0);
  if (!winding_up) s.integral = candidate_integral;
  s.saturated = output != unclamped;
  return output;
}

}  // namespace tribo::daemon
