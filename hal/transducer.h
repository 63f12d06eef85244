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
#include <string>
#include <string_view>

namespace tribo::hal {

struct SensorFrame {
  double normal_force_n = 0;
  double normal_displacement_m = 0;
  double lateral_force_n = 0;
  double lateral_position_m = 0;
  std::uint32_t status_bits = 0;  // backend-specific health bits (SensorStatus)
  // Readout noise that the record carries on top of lateral_position_m and
  // the loop does not see (the simulated instrument's acquisition chain,
  // Table 3.2's 10 nm floor). 0 for a backend whose record is its loop reading.
  double lateral_position_record_noise_m = 0;

  // The lateral position as recorded. Without record noise exactly the
  // loop's reading (x + 0 would turn -0 into +0).
  double recorded_lateral_position_m() const {
    return lateral_position_record_noise_m == 0 ? lateral_position_m
                                                : lateral_position_m + lateral_position_record_noise_m;
  }
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

// On anything but kOk a real backend sets the frame's values to NaN: a failed
// read never hands on a stale value. health().last_error says why.
enum class IoResult {
  kOk,
  kTimeout,   // no valid, fresh answer in time (timeout, exception, corrupt or stale data)
  kLinkDown,  // backend unreachable
};

// What the backend's link did so far (a real backend's I/O; the simulated one
// has none). Read from other threads while the loop runs: implementations
// keep it in atomics. Mirrored by tribo.v1.BackendHealth.
struct BackendHealth {
  bool connected = true;
  std::uint64_t transactions = 0;        // completed successfully
  std::uint64_t timeouts = 0;            // no complete answer in time
  std::uint64_t exceptions = 0;          // the device answered with an exception
  std::uint64_t bad_frames = 0;          // malformed, corrupt or stale answers
  std::uint64_t link_losses = 0;
  std::uint64_t reconnect_attempts = 0;
  double last_io_s = 0;                  // duration of the last transaction
  double max_io_s = 0;
  std::string first_error;               // the first failure: the cause of what followed
  std::string last_error;                // the latest failure; empty if none

  std::uint64_t errors() const { return timeouts + exceptions + bad_frames + link_losses; }
};

class Transducer {
 public:
  virtual ~Transducer() = default;

  virtual std::string_view backend_name() const = 0;
  virtual double period_s() const = 0;

  virtual IoResult read(SensorFrame& frame) = 0;
  virtual IoResult write(const DriveCommand& command) = 0;

  // Returns at the start of the next tick, or earlier once interrupt_wait()
  // was called (the loop then acts on what interrupted it at once).
  virtual void wait_next_tick() = 0;

  // Safe from any thread while the loop runs (an emergency stop posted by
  // the API thread): ends the present wait_next_tick() early, or the next
  // one if the loop is not waiting now. A backend whose wait does not sleep
  // (the simulated one, unpaced) returns at once anyway. Allocation- and
  // lock-free (hal/tick_wake.h).
  virtual void interrupt_wait() = 0;

  // Ticks whose deadline had already passed when wait_next_tick() was called.
  virtual std::uint64_t overruns() const { return 0; }

  // Safe to call from any thread while the loop runs.
  virtual BackendHealth health() const { return {}; }

  // Session lifecycle. A backend is created once per daemon and lives across
  // runs: it is the instrument, and between runs it keeps whatever state the
  // instrument is in (a re-arm reads that state, not a fresh one). A run (or
  // another activity that needs a defined start) begins a session: the
  // simulated backend restarts its plant at rest with the seed, so runs stay
  // bit-identical; the Modbus backend sends the session reset its device map
  // has (the bench emulator's seed), a real instrument simply continues.
  virtual void begin_session(std::uint64_t seed) { (void)seed; }
};

}  // namespace tribo::hal
