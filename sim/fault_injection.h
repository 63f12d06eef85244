// Fault injection for the simulated instrument: a scripted schedule of faults
// (tribo.v1.FaultSchedule, proto/tribo/v1/faults.proto) applied between the
// plant and the controller, the way a failing sensor, actuator, link or host
// would appear to it. The plant itself stays honest: a frozen sensor freezes
// the reading, not the tip; a stuck actuator holds the force the plant feels.
//
// A fault is active while start_s <= t < start_s + duration_s (duration 0:
// to the end of the run), t being the plant time at the tick's read. Noise
// bursts draw from their own stream of the run's seed, so a faulted run is
// bit-for-bit reproducible and the sensor noise streams are never shifted.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/instrument.h"
#include "sim/noise_source.h"
#include "tribo/v1/faults.pb.h"

namespace tribo::sim {

enum class FaultKind : std::uint8_t {
  kSensorDropout,
  kSensorFreeze,
  kSensorNan,
  kSensorOffset,
  kNoiseBurst,
  kActuatorStuck,
  kLinkDown,
  kReadTimeout,
  kLoopOverrun,
};

enum class FaultChannel : std::uint8_t {
  kNone,
  kLateralPosition,
  kLateralForce,
  kNormalForce,
  kNormalDisplacement,
  kLateralActuator,
  kNormalActuator,
};

struct FaultSpec {
  FaultKind kind = FaultKind::kSensorDropout;
  FaultChannel channel = FaultChannel::kNone;
  double start_s = 0;
  double duration_s = 0;  // 0: until the end
  double value = 0;
  bool use_value = false;
};

std::vector<FaultSpec> fault_schedule_from_config(const v1::FaultSchedule& schedule);

// nullopt when usable, else "sim.faults.faults[i].<field> = value: reason".
std::optional<std::string> validate_fault_schedule(const v1::FaultSchedule& schedule);

class FaultInjector {
 public:
  FaultInjector() = default;
  FaultInjector(std::vector<FaultSpec> faults, std::uint64_t seed);

  bool empty() const { return faults_.empty(); }

  // Moves to plant time t (the coming tick's read); captures frozen and
  // stuck values when their fault starts. drive: the drive applied so far.
  void advance(double time_s, const DriveInput& drive);

  // The reading the controller gets.
  Measurement corrupt(const Measurement& reading);
  // The drive the plant feels.
  DriveInput actuate(const DriveInput& commanded) const;

  bool link_down() const { return link_down_; }
  bool read_timeout() const { return read_timeout_; }
  std::uint64_t overruns() const { return overruns_; }

 private:
  struct Active {
    bool on = false;
    double captured = 0;  // frozen reading or stuck drive
  };

  std::vector<FaultSpec> faults_;
  std::vector<Active> active_;
  NoiseSource noise_{0};
  Measurement last_reported_;
  bool link_down_ = false;
  bool read_timeout_ = false;
  std::uint64_t overruns_ = 0;
};

}  // namespace tribo::sim
