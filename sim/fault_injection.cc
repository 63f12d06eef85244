#include "sim/fault_injection.h"

#include <cmath>
#include <limits>
#include <sstream>

namespace tribo::sim {

namespace {

// Stream id of the noise-burst generator (sim/instrument.cc owns 1-4).
constexpr std::uint64_t kFaultNoiseStream = 0xFA17;

double* channel_value(Measurement& m, FaultChannel c) {
  switch (c) {
    case FaultChannel::kLateralPosition: return &m.lateral_position_m;
    case FaultChannel::kLateralForce: return &m.lateral_force_n;
    case FaultChannel::kNormalForce: return &m.normal_force_n;
    case FaultChannel::kNormalDisplacement: return &m.normal_displacement_m;
    default: return nullptr;
  }
}

bool is_sensor_fault(FaultKind k) {
  return k == FaultKind::kSensorDropout || k == FaultKind::kSensorFreeze || k == FaultKind::kSensorNan ||
         k == FaultKind::kSensorOffset || k == FaultKind::kNoiseBurst;
}

}  // namespace

std::vector<FaultSpec> fault_schedule_from_config(const v1::FaultSchedule& schedule) {
  std::vector<FaultSpec> out;
  for (const v1::InjectedFault& f : schedule.faults()) {
    FaultSpec s;
    switch (f.kind()) {
      case v1::SENSOR_FREEZE: s.kind = FaultKind::kSensorFreeze; break;
      case v1::SENSOR_NAN: s.kind = FaultKind::kSensorNan; break;
      case v1::SENSOR_OFFSET: s.kind = FaultKind::kSensorOffset; break;
      case v1::NOISE_BURST: s.kind = FaultKind::kNoiseBurst; break;
      case v1::ACTUATOR_STUCK: s.kind = FaultKind::kActuatorStuck; break;
      case v1::LINK_DOWN: s.kind = FaultKind::kLinkDown; break;
      case v1::READ_TIMEOUT: s.kind = FaultKind::kReadTimeout; break;
      case v1::LOOP_OVERRUN: s.kind = FaultKind::kLoopOverrun; break;
      default: s.kind = FaultKind::kSensorDropout; break;
    }
    switch (f.channel()) {
      case v1::CHANNEL_LATERAL_POSITION: s.channel = FaultChannel::kLateralPosition; break;
      case v1::CHANNEL_LATERAL_FORCE: s.channel = FaultChannel::kLateralForce; break;
      case v1::CHANNEL_NORMAL_FORCE: s.channel = FaultChannel::kNormalForce; break;
      case v1::CHANNEL_NORMAL_DISPLACEMENT: s.channel = FaultChannel::kNormalDisplacement; break;
      case v1::CHANNEL_LATERAL_ACTUATOR: s.channel = FaultChannel::kLateralActuator; break;
      case v1::CHANNEL_NORMAL_ACTUATOR: s.channel = FaultChannel::kNormalActuator; break;
      default: s.channel = FaultChannel::kNone; break;
    }
    s.start_s = f.start_s();
    s.duration_s = f.duration_s();
    s.value = f.value();
    s.use_value = f.use_value();
    out.push_back(s);
  }
  return out;
}

std::optional<std::string> validate_fault_schedule(const v1::FaultSchedule& schedule) {
  for (int i = 0; i < schedule.faults_size(); ++i) {
    const v1::InjectedFault& f = schedule.faults(i);
    const std::string at = "sim.faults.faults[" + std::to_string(i) + "].";
    std::ostringstream msg;
    if (f.kind() == v1::FAULT_KIND_UNSPECIFIED || !v1::FaultKind_IsValid(f.kind())) {
      return at + "kind is not set";
    }
    if (!(f.start_s() >= 0) || !std::isfinite(f.start_s())) {
      msg << at << "start_s = " << f.start_s() << ": must be >= 0";
      return msg.str();
    }
    if (!(f.duration_s() >= 0) || !std::isfinite(f.duration_s())) {
      msg << at << "duration_s = " << f.duration_s() << ": must be >= 0 (0: to the end)";
      return msg.str();
    }
    const bool sensor = f.kind() == v1::SENSOR_DROPOUT || f.kind() == v1::SENSOR_FREEZE ||
                        f.kind() == v1::SENSOR_NAN || f.kind() == v1::SENSOR_OFFSET ||
                        f.kind() == v1::NOISE_BURST;
    const bool sensor_channel = f.channel() >= v1::CHANNEL_LATERAL_POSITION && f.channel() <= v1::CHANNEL_NORMAL_DISPLACEMENT;
    const bool actuator_channel = f.channel() == v1::CHANNEL_LATERAL_ACTUATOR || f.channel() == v1::CHANNEL_NORMAL_ACTUATOR;
    if (sensor && !sensor_channel) {
      return at + "channel = " + v1::FaultChannel_Name(f.channel()) + ": " + v1::FaultKind_Name(f.kind()) +
             " needs a sensor channel";
    }
    if (f.kind() == v1::ACTUATOR_STUCK && !actuator_channel) {
      return at + "channel = " + v1::FaultChannel_Name(f.channel()) + ": ACTUATOR_STUCK needs an actuator channel";
    }
    if (!std::isfinite(f.value()) || (f.kind() == v1::NOISE_BURST && !(f.value() >= 0))) {
      msg << at << "value = " << f.value() << ": must be finite (and >= 0 for NOISE_BURST)";
      return msg.str();
    }
  }
  return std::nullopt;
}

FaultInjector::FaultInjector(std::vector<FaultSpec> faults, std::uint64_t seed)
    : faults_(std::move(faults)), active_(faults_.size()), noise_(derive_seed(seed, kFaultNoiseStream)) {}

void FaultInjector::advance(double time_s, const DriveInput& drive) {
  link_down_ = false;
  read_timeout_ = false;
  // Half a nanosecond of slack: tick times are sums of the period.
  constexpr double kSlack = 0.5e-9;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    const bool on = time_s + kSlack >= f.start_s &&
                    (f.duration_s == 0 || time_s + kSlack < f.start_s + f.duration_s);
    if (on && !active_[i].on) {
      if (f.kind == FaultKind::kSensorFreeze) {
        Measurement last = last_reported_;
        if (const double* v = channel_value(last, f.channel)) active_[i].captured = *v;
      } else if (f.kind == FaultKind::kActuatorStuck) {
        const double present = f.channel == FaultChannel::kLateralActuator ? drive.lateral_force_n
                                                                            : drive.normal_force_n;
        active_[i].captured = f.use_value ? f.value : present;
      }
    }
    active_[i].on = on;
    if (!on) continue;
    if (f.kind == FaultKind::kLinkDown) link_down_ = true;
    if (f.kind == FaultKind::kReadTimeout) read_timeout_ = true;
    if (f.kind == FaultKind::kLoopOverrun) ++overruns_;
  }
}

Measurement FaultInjector::corrupt(const Measurement& reading) {
  Measurement m = reading;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    if (!active_[i].on || !is_sensor_fault(f.kind)) continue;
    double* v = channel_value(m, f.channel);
    if (!v) continue;
    switch (f.kind) {
      case FaultKind::kSensorDropout: *v = 0; break;
      case FaultKind::kSensorFreeze: *v = active_[i].captured; break;
      case FaultKind::kSensorNan: *v = std::numeric_limits<double>::quiet_NaN(); break;
      case FaultKind::kSensorOffset: *v += f.value; break;
      case FaultKind::kNoiseBurst: *v += f.value * noise_.gaussian(); break;
      default: break;
    }
  }
  last_reported_ = m;
  return m;
}

DriveInput FaultInjector::actuate(const DriveInput& commanded) const {
  DriveInput d = commanded;
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultSpec& f = faults_[i];
    if (!active_[i].on || f.kind != FaultKind::kActuatorStuck) continue;
    if (f.channel == FaultChannel::kLateralActuator) d.lateral_force_n = active_[i].captured;
    if (f.channel == FaultChannel::kNormalActuator) d.normal_force_n = active_[i].captured;
  }
  return d;
}

}  // namespace tribo::sim
