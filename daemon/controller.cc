#include "daemon/controller.h"

#include <cmath>

#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

namespace {

AntiWindup anti_windup_from_proto(v1::AntiWindup a) {
  switch (a) {
    case v1::ANTI_WINDUP_NONE: return AntiWindup::kNone;
    case v1::BACK_CALCULATION: return AntiWindup::kBackCalculation;
    default: return AntiWindup::kConditionalIntegration;
  }
}

v1::AntiWindup anti_windup_to_proto(AntiWindup a) {
  switch (a) {
    case AntiWindup::kNone: return v1::ANTI_WINDUP_NONE;
    case AntiWindup::kBackCalculation: return v1::BACK_CALCULATION;
    case AntiWindup::kConditionalIntegration: break;
  }
  return v1::CONDITIONAL_INTEGRATION;
}

}  // namespace

PidGains pid_gains_from_proto(const v1::PidGains& g) {
  PidGains p;
  p.kp = g.kp();
  p.ki = g.ki();
  p.kd = g.kd();
  p.setpoint_weight_p = g.setpoint_weight_p();
  p.setpoint_weight_d = g.setpoint_weight_d();
  p.derivative_filter_hz = g.derivative_filter_hz();
  p.output_min = g.output_min();
  p.output_max = g.output_max();
  p.anti_windup = anti_windup_from_proto(g.anti_windup());
  p.tracking_time_s = g.tracking_time_s();
  p.feedforward_gain = g.feedforward_gain();
  return p;
}

v1::PidGains pid_gains_to_proto(const PidGains& p) {
  v1::PidGains g;
  g.set_kp(p.kp);
  g.set_ki(p.ki);
  g.set_kd(p.kd);
  g.set_setpoint_weight_p(p.setpoint_weight_p);
  g.set_setpoint_weight_d(p.setpoint_weight_d);
  g.set_derivative_filter_hz(p.derivative_filter_hz);
  g.set_output_min(p.output_min);
  g.set_output_max(p.output_max);
  g.set_anti_windup(anti_windup_to_proto(p.anti_windup));
  g.set_tracking_time_s(p.tracking_time_s);
  g.set_feedforward_gain(p.feedforward_gain);
  return g;
}

ControllerParams controller_params_from_config(const v1::ControllerConfig& c) {
  ControllerParams p;
  p.lateral = pid_gains_from_proto(c.lateral_displacement());
  p.lateral_force = pid_gains_from_proto(c.lateral_force());
  p.normal_force = pid_gains_from_proto(c.normal_force());
  p.normal_displacement = pid_gains_from_proto(c.normal_displacement());
  p.period_s = 1.0 / c.loop_rate_hz();
  p.friction_observer.observer_gain_per_s = c.friction_compensation().observer_gain_per_s();
  p.friction_observer.velocity_filter_hz = c.friction_compensation().velocity_filter_hz();
  p.friction_observer.contact_state_from_measured = c.friction_compensation().contact_state_from_measured_velocity();
  p.friction_observer.velocity = c.friction_compensation().velocity_source() == v1::MEASURED
                                     ? ObserverVelocity::kMeasured
                                     : ObserverVelocity::kCommanded;
  p.friction_velocity_delay_ticks =
      static_cast<std::size_t>(std::lround(c.friction_compensation().velocity_delay_s() * c.loop_rate_hz()));
  p.friction_velocity_lag_s = c.friction_compensation().velocity_lag_s();
  return p;
}

ControllerParams controller_params_from_config(const v1::DaemonConfig& config) {
  ControllerParams p = controller_params_from_config(config.controller());
  p.lateral_spring_n_per_m = config.transducer().lateral().spring_n_per_m();
  p.normal_spring_n_per_m = config.transducer().normal().spring_n_per_m();
  return p;
}

Controller::Controller(const ControllerParams& params)
    : params_(params),
      lateral_terms_(pid_terms(params.lateral, params.period_s)),
      lateral_force_terms_(pid_terms(params.lateral_force, params.period_s)),
      normal_force_terms_(pid_terms(params.normal_force, params.period_s)),
      normal_displacement_terms_(pid_terms(params.normal_displacement, params.period_s)),
      observer_velocity_delay_(params.friction_velocity_delay_ticks) {}

PidTerms& Controller::terms_ref(Loop loop) {
  switch (loop) {
    case Loop::kLateralDisplacement: return lateral_terms_;
    case Loop::kLateralForce: return lateral_force_terms_;
    case Loop::kNormalForce: return normal_force_terms_;
    case Loop::kNormalDisplacement: break;
  }
  return normal_displacement_terms_;
}

PidGains& Controller::gains_ref(Loop loop) {
  switch (loop) {
    case Loop::kLateralDisplacement: return params_.lateral;
    case Loop::kLateralForce: return params_.lateral_force;
    case Loop::kNormalForce: return params_.normal_force;
    case Loop::kNormalDisplacement: break;
  }
  return params_.normal_displacement;
}

PidState& Controller::state_ref(Loop loop) {
  switch (loop) {
    case Loop::kLateralDisplacement: return lateral_displacement_;
    case Loop::kLateralForce: return lateral_force_;
    case Loop::kNormalForce: return normal_force_;
    case Loop::kNormalDisplacement: break;
  }
  return normal_displacement_;
}

const PidGains& Controller::gains(Loop loop) const {
  return const_cast<Controller*>(this)->gains_ref(loop);
}

void Controller::set_gains(Loop loop, const PidGains& gains) {
  pid_change_gains(gains_ref(loop), gains, state_ref(loop));
  gains_ref(loop) = gains;
  terms_ref(loop) = pid_terms(gains, params_.period_s);
}

ControlOutput Controller::step(const Setpoints& sp, const hal::SensorFrame& sensors) {
  TickSetpoints t;
  t.segment = sp.segment;
  t.ticks_per_sample = sp.ticks_per_sample;
  t.normal = sp.normal_force_n;
  t.lateral = sp.lateral_position_m;
  return step(t, sensors);
}

ControlOutput Controller::step(const TickSetpoints& sp, const hal::SensorFrame& f) {
  ControlOutput out;
  drive_.normal_force_n = normal_step(sp, f, out);
  drive_.lateral_force_n = lateral_step(sp, f, out);
  out.drive = drive_;
  return out;
}

double Controller::normal_step(const TickSetpoints& sp, const hal::SensorFrame& f,
                               ControlOutput& out) {
  const double k = params_.normal_spring_n_per_m;
  const bool enter = !normal_active_ || sp.normal_mode != normal_mode_;
  normal_active_ = true;
  normal_mode_ = sp.normal_mode;
  out.normal_setpoint_n = sp.normal;
  switch (sp.normal_mode) {
    case NormalMode::kOpenLoopForce:
      return sp.normal;
    case NormalMode::kClosedLoopForce: {
      out.flags |= v1::NORMAL_CLOSED_LOOP;
      const PidGains& g = params_.normal_force;
      if (enter) pid_reset(g, sp.normal, f.normal_force_n, sp.normal, drive_.normal_force_n, normal_force_);
      const double u = pid_update(g, normal_force_terms_, sp.normal, f.normal_force_n, sp.normal, params_.period_s,
                                  normal_force_);
      if (normal_force_.input_invalid) out.flags |= v1::SENSOR_INVALID;
      return u;
    }
    case NormalMode::kDisplacement: {
      out.flags |= v1::NORMAL_CLOSED_LOOP;
      const PidGains& g = params_.normal_displacement;
      const double ff = k * sp.normal;
      if (enter) pid_reset(g, sp.normal, f.normal_displacement_m, ff, drive_.normal_force_n, normal_displacement_);
      const double u = pid_update(g, normal_displacement_terms_, sp.normal, f.normal_displacement_m, ff, params_.period_s,
                                  normal_displacement_);
      if (normal_displacement_.input_invalid) out.flags |= v1::SENSOR_INVALID;
      out.normal_setpoint_n = u;  // the recorded normal setpoint is the commanded drive
      return u;
    }
  }
  return drive_.normal_force_n;
}

double Controller::lateral_hold(const hal::SensorFrame& f, ControlOutput& out) {
  const PidGains& g = params_.lateral;
  const double ff = params_.lateral_spring_n_per_m * hold_position_m_;
  const double u = pid_update(g, lateral_terms_, hold_position_m_, f.lateral_position_m, ff, params_.period_s,
                              lateral_displacement_);
  if (lateral_displacement_.input_invalid) out.flags |= v1::SENSOR_INVALID;
  if (lateral_displacement_.saturated) out.flags |= v1::LATERAL_OUTPUT_SATURATED;
  out.lateral_setpoint_m = hold_position_m_;
  return u;
}

// The commanded velocity as the lagging tip will follow it: delayed, then
// lagged (backward Euler of dv/dt = (v_c - v) / tau).
double Controller::observer_velocity(double commanded_m_per_s) {
  const double delayed = observer_velocity_delay_.push(commanded_m_per_s);
  const double tau = params_.friction_velocity_lag_s;
  if (!(tau > 0)) return delayed;
  const double h = params_.period_s;
  observer_velocity_lagged_ += h / (tau + h) * (delayed - observer_velocity_lagged_);
  return observer_velocity_lagged_;
}

double Controller::friction_compensation(const TickSetpoints& sp, const hal::SensorFrame& f, ControlOutput& out) {
  const bool switched = sp.friction_model != compensating_;
  if (switched && !sp.friction_model) {  // off: the integrator takes over the share
    pid_shift_added(compensation_n_, 0.0, lateral_displacement_);
    compensating_ = nullptr;
    compensation_n_ = 0;
    return 0.0;
  }
  if (!sp.friction_model) return 0.0;
  if (!compensating_) {
    observer_ = observer_at_rest(*sp.friction_model);
    observer_velocity_delay_.fill(0.0);
    observer_velocity_lagged_ = 0;
  }
  compensating_ = sp.friction_model;
  ObserverInput in;
  in.position_m = f.lateral_position_m;
  in.position_error_m = f.lateral_position_m - sp.lateral;
  in.normal_force_n = f.normal_force_n;
  in.commanded_velocity_m_per_s = observer_velocity(sp.lateral_rate);
  in.period_s = params_.period_s;
  const ObserverOutput o = observer_step(*compensating_, params_.friction_observer, in, observer_);
  // A reading that is not finite leaves the state and the share as they
  // were (the PID holds its drive too); a model that yields a non-finite
  // force passes it on, and the supervisor refuses the command.
  const double share = o.advanced ? o.force_n : compensation_n_;
  // Switched on, or to another model: the integrator gives up the new share.
  if (switched && std::isfinite(share)) pid_shift_added(compensation_n_, share, lateral_displacement_);
  compensation_n_ = share;
  out.friction_compensation_n = share;
  out.friction_compensated = true;
  out.flags |= v1::FRICTION_COMPENSATED;
  return share;
}

double Controller::lateral_step(const TickSetpoints& sp, const hal::SensorFrame& f,
                                ControlOutput& out) {
  const double k = params_.lateral_spring_n_per_m;
  const double x = f.lateral_position_m;
  const bool new_mode = !lateral_active_ || sp.lateral_mode != lateral_mode_;
  // A force segment restarts its loop after a break-away hold in the previous one.
  const bool enter = new_mode || (sp.segment_start && sp.lateral_mode == LateralMode::kForce && breakaway_);
  lateral_active_ = true;
  lateral_mode_ = sp.lateral_mode;
  if (new_mode || sp.segment_start) {
    breakaway_ = false;
    excursion_origin_m_ = x;
  }
  switch (sp.lateral_mode) {
    case LateralMode::kDisplacement: {
      const PidGains& g = params_.lateral;
      const double ff = k * sp.lateral;
      if (enter) {
        pid_reset(g, sp.lateral, std::isfinite(x) ? x : sp.lateral, ff, drive_.lateral_force_n, lateral_displacement_,
                  compensation_n_);
      }
      const double compensation = friction_compensation(sp, f, out);
      const double u =
          pid_update(g, lateral_terms_, sp.lateral, x, ff, params_.period_s, lateral_displacement_, compensation);
      if (lateral_displacement_.input_invalid) out.flags |= v1::SENSOR_INVALID;
      if (lateral_displacement_.saturated) out.flags |= v1::LATERAL_OUTPUT_SATURATED;
      out.lateral_setpoint_m = sp.lateral;
      return u;
    }
    case LateralMode::kForce: {
      out.flags |= v1::LATERAL_FORCE_CONTROL;
      if (compensating_) {  // no compensation in force control: the integrator takes its share
        pid_shift_added(compensation_n_, 0.0, lateral_displacement_);
        compensating_ = nullptr;
        compensation_n_ = 0;
      }
      out.lateral_setpoint_m = x;
      if (!breakaway_ && std::isfinite(x) && std::isfinite(excursion_origin_m_) &&
          std::fabs(x - excursion_origin_m_) > sp.max_excursion_m) {
        breakaway_ = true;
        hold_position_m_ = x;
        pid_reset(params_.lateral, x, x, k * x, drive_.lateral_force_n, lateral_displacement_);
      }
      if (breakaway_) {
        out.flags |= v1::BREAKAWAY_HOLD;
        return lateral_hold(f, out);
      }
      const PidGains& g = params_.lateral_force;
      const double ff = sp.lateral + k * x;
      if (enter) {
        pid_reset(g, sp.lateral, std::isfinite(f.lateral_force_n) ? f.lateral_force_n : sp.lateral,
                  std::isfinite(ff) ? ff : sp.lateral, drive_.lateral_force_n, lateral_force_);
      }
      const double u = pid_update(g, lateral_force_terms_, sp.lateral, f.lateral_force_n, ff, params_.period_s,
                                  lateral_force_);
      if (lateral_force_.input_invalid) out.flags |= v1::SENSOR_INVALID;
      if (lateral_force_.saturated) out.flags |= v1::LATERAL_OUTPUT_SATURATED;
      return u;
    }
    case LateralMode::kOpenLoopDrive:
      out.lateral_setpoint_m = x;
      compensating_ = nullptr;
      compensation_n_ = 0;
      return sp.lateral;
  }
  return drive_.lateral_force_n;
}

}  // namespace tribo::daemon
