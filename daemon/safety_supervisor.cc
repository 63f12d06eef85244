#include "daemon/safety_supervisor.h"

#include <cmath>

namespace tribo::daemon {

SafetyLimits safety_limits_from_config(const v1::InstrumentLimits& l) {
  return SafetyLimits{l.max_normal_force_n(), l.max_lateral_force_n(), l.max_lateral_travel_m()};
}

std::string_view trip_reason_text(TripReason reason) {
  switch (reason) {
    case TripReason::kNone: return "none";
    case TripReason::kSensorNotFinite: return "sensor reading is not finite";
    case TripReason::kLateralTravel: return "lateral position beyond the travel limit";
    case TripReason::kLateralForce: return "lateral force beyond the limit";
    case TripReason::kNormalForce: return "normal force beyond the limit";
  }
  return "unknown";
}

TripReason SafetySupervisor::check(const hal::SensorFrame& f) {
  if (tripped_ != TripReason::kNone) return TripReason::kNone;
  TripReason reason = TripReason::kNone;
  if (!std::isfinite(f.lateral_position_m) || !std::isfinite(f.lateral_force_n) ||
      !std::isfinite(f.normal_force_n) || !std::isfinite(f.normal_displacement_m)) {
    reason = TripReason::kSensorNotFinite;
  } else if (std::fabs(f.lateral_position_m) > limits_.max_lateral_travel_m) {
    reason = TripReason::kLateralTravel;
  } else if (std::fabs(f.lateral_force_n) > limits_.max_lateral_force_n) {
    reason = TripReason::kLateralForce;
  } else if (f.normal_force_n > limits_.max_normal_force_n) {
    reason = TripReason::kNormalForce;
  }
  tripped_ = reason;
  return reason;
}

}  // namespace tribo::daemon
