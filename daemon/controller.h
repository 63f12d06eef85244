// The control law of one tick: open-loop normal force, and a PID on the
// measured lateral position producing the lateral actuator force.
#pragma once

#include <cstdint>

#include "daemon/load_function.h"
#include "daemon/pid.h"
#include "hal/transducer.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

struct ControllerParams {
  PidGains lateral;
  double period_s = 0;
};

PidGains pid_gains_from_proto(const v1::PidGains& gains);
ControllerParams controller_params_from_config(const v1::ControllerConfig& config);

struct ControlOutput {
  hal::DriveCommand drive;
  std::uint32_t flags = 0;  // tribo.v1.StatusFlag bits
};

class Controller {
 public:
  explicit Controller(const ControllerParams& params);

  ControlOutput step(const Setpoints& setpoints, const hal::SensorFrame& sensors);

 private:
  ControllerParams params_;
  PidState lateral_;
  double last_lateral_drive_n_ = 0;
};

}  // namespace tribo::daemon
