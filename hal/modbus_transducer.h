// The real backend: the instrument (or tribo-bench) over Modbus, TCP or RTU.
// Each tick reads the sensor block in one transaction and writes the drive
// block in one; wait_next_tick() sleeps to the next absolute deadline.
//
// Lock-step handshake (docs/modbus.md): the sensor block
// carries the instrument's sample sequence number, the drive block the
// sequence it answers plus one. A frame is used only if its sequence is newer
// than the last one used, so a missed step, a late or replayed answer is never
// taken for fresh data. An emulator steps its plant once per drive write whose
// sequence is its own plus one, so the plant and the controller stay in step
// however the wall clock jitters.
//
// On any failure read() returns kTimeout or kLinkDown with NaN values and
// health().last_error says why; the supervisor turns that into a fault.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "hal/modbus_blocks.h"
#include "hal/modbus_link.h"
#include "hal/modbus_register_map.h"
#include "hal/transducer.h"
#include "hal/wall_clock_pacer.h"

namespace tribo::hal {

class ModbusTransducer : public Transducer {
 public:
  // Connects, checks the identity block and starts the session (seed, reset)
  // right away; if that fails the run's first read reports it.
  ModbusTransducer(const LinkSettings& link, const RegisterMap& map, double loop_rate_hz, std::uint64_t seed);

  std::string_view backend_name() const override { return "modbus"; }
  double period_s() const override { return period_s_; }
  IoResult read(SensorFrame& frame) override;
  IoResult write(const DriveCommand& command) override;
  void wait_next_tick() override;
  // Ends the sleep to the next deadline; a transaction in progress runs to
  // its end (or its timeout) first.
  void interrupt_wait() override { wake_.wake(); }
  // Sends the session reset (seed) before the next read, where the device map
  // has a session block; the pacer starts again with the next tick.
  void begin_session(std::uint64_t seed) override;
  std::uint64_t overruns() const override { return pacer_ ? pacer_->overruns() : 0; }
  BackendHealth health() const override { return link_.health(); }

 private:
  IoResult prepare_link();
  IoResult check_identity();
  IoResult start_session();
  void note_over_range(const SensorBlockValues& values);

  ModbusLink link_;
  RegisterMap map_;
  double period_s_;
  std::uint64_t seed_;
  TickWake wake_;  // outlives every pacer_
  std::optional<WallClockPacer> pacer_;  // starts with the first tick

  std::uint64_t connections_seen_ = 0;
  bool identity_pending_ = false;
  bool session_pending_ = false;
  std::optional<std::uint32_t> last_used_sequence_;
  std::uint32_t last_seen_sequence_ = 0;
  AxisPositions positions_;  // last finite measured positions: the actuators' gaps
  struct LogLimit {  // at most one log line per interval
    std::int64_t interval_ns;
    std::int64_t last_ns = -interval_ns;
    bool due(std::int64_t now) {
      if (now - last_ns < interval_ns) return false;
      last_ns = now;
      return true;
    }
  };
  LogLimit over_range_log_;
  LogLimit clamp_log_;

  std::array<std::uint16_t, 125> sensor_registers_{};
  std::array<std::uint16_t, 123> drive_registers_{};
};

}  // namespace tribo::hal
