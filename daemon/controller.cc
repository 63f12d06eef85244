#include "daemon/controller.h"

#include <cmath>

#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

PidGains pid_gains_from_proto(const v1::PidGains& g) {
  return PidGains{g.kp(), g.ki(), g.kd(), g.setpoint_weight_p(), g.setpoint_weight_d(),
                  g.derivative_filter_hz(), g.output_min(), g.output_max()};
}

ControllerParams controller_params_from_config(const v1::ControllerConfig& c) {
  return ControllerParams{pid_gains_from_proto(c.lateral_displacement()), 1.0 / c.loop_rate_hz()};
}

Controller::Controller(const ControllerParams& params) : params_(params) {
  pid_reset(params_.lateral, 0.0, 0.0, 0.0, lateral_);
}

ControlOutput Controller::step(const Setpoints& sp, const hal::SensorFrame& sensors) {
  ControlOutput out;
  out.drive.normal_force_n = sp.normal_force_n;
  if (std::isfinite(sensors.lateral_position_m)) {
    last_lateral_drive_n_ = pid_update(params_.lateral, sp.lateral_position_m,
                                       sensors.lateral_position_m, params_.period_s, lateral_);
    if (lateral_.saturated) out.flags |= v1::LATERAL_OUTPUT_SATURATED;
  } else {
    out.flags |= v1::SENSOR_INVALID;  // hold the last drive; never feed NaN forward
  }
  out.drive.lateral_force_n = last_lateral_drive_n_;
  return out;
}

}  // namespace tribo::daemon
