// Checks every tick, before commands reach the HAL. This version trips on
// sensor values that are not finite, lateral travel and force beyond the
// instrument's limits, and normal force beyond its limit. A trip latches: the
// run loop then unloads safely and ends the run with the recorded reason.
#pragma once

#include <string_view>

#include "hal/transducer.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

struct SafetyLimits {
  double max_normal_force_n = 0;
  double max_lateral_force_n = 0;
  double max_lateral_travel_m = 0;
};

SafetyLimits safety_limits_from_config(const v1::InstrumentLimits& limits);

enum class TripReason {
  kNone,
  kSensorNotFinite,
  kLateralTravel,
  kLateralForce,
  kNormalForce,
};

std::string_view trip_reason_text(TripReason reason);

class SafetySupervisor {
 public:
  explicit SafetySupervisor(const SafetyLimits& limits) : limits_(limits) {}

  // Returns the reason of a new trip, or kNone. After a trip it keeps
  // returning kNone; tripped() stays latched.
  TripReason check(const hal::SensorFrame& frame);

  TripReason tripped() const { return tripped_; }

 private:
  SafetyLimits limits_;
  TripReason tripped_ = TripReason::kNone;
};

}  // namespace tribo::daemon
