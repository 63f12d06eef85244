// The hardware interface: one small contract that the simulated and the real
// (Modbus) transducer backends both implement. The controller sees only this.
//
// A tick is: read() the sensors, compute, write() the drive, wait_next_tick().
// The backend owns the clock: the simulated one advances its plant by one
// nominal period in wait_next_tick() (lock-step), a real one sleeps until the
// next absolute deadline. The controller uses the nominal period, never a
// measured one, so runs are reproducible.
#pragma once

#include <cstdint>
#include <string_view>

namespace tribo::hal {

struct SensorFrame {
  double normal_force_n = 0;
  double normal_displacement_m = 0;
  double lateral_force_n = 0;
  double lateral_position_m = 0;
  std::uint32_t status_bits = 0;  // backend-specific health bits (SensorStatus)
};

enum SensorStatus : std::uint32_t {
  kSensorOk = 0,
  kSubstepCapHit = 1u << 0,  // simulated backend: the plant asked for more sub-steps than allowed
  kLateralSnapDown = 1u << 1,  // the lateral centre plate snapped onto a drive plate's stop
  kDriveHandover = 1u << 2,    // breakpoint: no lateral drive plate was driven this tick
};

struct DriveCommand {
  double normal_force_n = 0;   // actuator force on the normal axis
  double lateral_force_n = 0;  // actuator force on the lateral axis
};

enum class IoResult {
  kOk,
  kTimeout,   // no answer in time; values not updated
  kLinkDown,  // backend unreachable
};

class Transducer {
 public:
  virtual ~Transducer() = default;

  virtual std::string_view backend_name() const = 0;
  virtual double period_s() const = 0;

  virtual IoResult read(SensorFrame& frame) = 0;
  virtual IoResult write(const DriveCommand& command) = 0;

  // Returns at the start of the next tick.
  virtual void wait_next_tick() = 0;

  // Ticks whose deadline had already passed when wait_next_tick() was called.
  virtual std::uint64_t overruns() const { return 0; }
};

}  // namespace tribo::hal
