#include "daemon/pid.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tribo::daemon {

namespace {

double proportional(const PidGains& g, double r, double y) {
  return g.kp * (g.setpoint_weight_p * r - y);
}

double filter_time_s(const PidGains& g) {
  return g.derivative_filter_hz > 0 ? 1.0 / (2.0 * std::numbers::pi * g.derivative_filter_hz) : 0.0;
}

}  // namespace

double pid_tracking_time_s(const PidGains& g, double dt_s) {
  if (g.tracking_time_s > 0) return g.tracking_time_s;
  if (!(g.kp > 0) || !(g.ki > 0)) return dt_s;
  const double ti = g.kp / g.ki;
  if (g.kd > 0) return std::sqrt(ti * g.kd / g.kp);
  return ti;
}

void pid_reset(const PidGains& g, double setpoint, double measurement, double feedforward,
               double output, PidState& s, double added) {
  s.derivative = 0;
  s.previous_d_input = g.setpoint_weight_d * setpoint - measurement;
  s.integral = output - proportional(g, setpoint, measurement) - g.feedforward_gain * feedforward - added;
  s.added = added;
  s.output = output;
  s.setpoint = setpoint;
  s.measurement = measurement;
  s.feedforward = feedforward;
  s.saturated = false;
  s.input_invalid = false;
}

PidTerms pid_terms(const PidGains& g, double dt_s) {
  PidTerms t;
  t.filter_time_s = filter_time_s(g);
  t.ki_dt = g.ki * dt_s;
  if (g.anti_windup == AntiWindup::kBackCalculation) {
    t.tracking_gain = std::min(1.0, dt_s / pid_tracking_time_s(g, dt_s));
  }
  return t;
}

double pid_update(const PidGains& g, double setpoint, double measurement, double feedforward,
                  double dt_s, PidState& s) {
  return pid_update(g, pid_terms(g, dt_s), setpoint, measurement, feedforward, dt_s, s);
}

double pid_update(const PidGains& g, const PidTerms& t, double setpoint, double measurement,
                  double feedforward, double dt_s, PidState& s, double added) {
  if (!(dt_s > 0) || !std::isfinite(dt_s) || !std::isfinite(setpoint) ||
      !std::isfinite(measurement) || !std::isfinite(feedforward) || !std::isfinite(added)) {
    s.input_invalid = true;
    return s.output;
  }
  s.input_invalid = false;
  const double error = setpoint - measurement;
  const double p = proportional(g, setpoint, measurement);

  const double d_input = g.setpoint_weight_d * setpoint - measurement;
  const double tf = t.filter_time_s;
  // A zero numerator divides to itself (its sign kept: tf + dt > 0): without
  // D (kd = 0, no filter memory) the division is skipped, same bits.
  const double d_numerator = tf * s.derivative + g.kd * (d_input - s.previous_d_input);
  s.derivative = d_numerator == 0 ? d_numerator : d_numerator / (tf + dt_s);
  s.previous_d_input = d_input;

  const double candidate = s.integral + t.ki_dt * error;
  // Without an added term the sum is the one before there was one (same bits).
  const double sum = p + candidate + s.derivative + g.feedforward_gain * feedforward;
  const double unclamped = added == 0 ? sum : sum + added;
  const double output = std::clamp(unclamped, g.output_min, g.output_max);
  switch (g.anti_windup) {
    case AntiWindup::kNone:
      s.integral = candidate;
      break;
    case AntiWindup::kConditionalIntegration: {
      const bool winding_up = (unclamped > g.output_max && error > 0) ||
                              (unclamped < g.output_min && error < 0);
      if (!winding_up) s.integral = candidate;
      break;
    }
    case AntiWindup::kBackCalculation:
      s.integral = candidate + t.tracking_gain * (output - unclamped);
      break;
  }
  s.saturated = output != unclamped;
  s.output = output;
  s.setpoint = setpoint;
  s.measurement = measurement;
  s.feedforward = feedforward;
  s.added = added;
  return output;
}

void pid_shift_added(double from, double to, PidState& s) {
  s.integral += from - to;
  s.added = to;
}

void pid_change_gains(const PidGains& old_gains, const PidGains& new_gains, PidState& s) {
  s.derivative = old_gains.kd > 0 ? s.derivative * (new_gains.kd / old_gains.kd) : 0.0;
  s.previous_d_input = new_gains.setpoint_weight_d * s.setpoint - s.measurement;
  s.integral = s.output - proportional(new_gains, s.setpoint, s.measurement) - s.derivative -
               new_gains.feedforward_gain * s.feedforward - s.added;
}

}  // namespace tribo::daemon
