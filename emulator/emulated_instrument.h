// The simulated instrument (sim::SimInstrument) behind the register map, as
// tribo-bench serves it: the registers a Modbus client sees, and the
// lock-step rule. Each drive block written with sequence = ours + 1 steps the
// plant once by the loop period and refreshes the sensor block with
// sequence + 1; a repeat of the present sequence is acknowledged without a
// step and any other is refused, so a repeated or late write can never step
// the plant twice. A session write (seed, reset) puts the plant at
// rest with that seed at sequence 0, as a new simulated run would.
#pragma once

#include <cstdint>
#include <memory>

#include "hal/modbus_register_map.h"
#include "sim/instrument.h"

typedef struct _modbus_mapping_t modbus_mapping_t;

namespace tribo::bench {

class EmulatedInstrument {
 public:
  EmulatedInstrument(const hal::RegisterMap& map, const sim::InstrumentParams& params, double step_period_s,
                     std::uint64_t seed);
  ~EmulatedInstrument();
  EmulatedInstrument(const EmulatedInstrument&) = delete;
  EmulatedInstrument& operator=(const EmulatedInstrument&) = delete;

  // The registers served (libmodbus mapping).
  modbus_mapping_t* mapping() { return mapping_; }
  std::uint16_t* table(hal::RegisterTable table);

  // Plant at rest, new noise seed, sequence 0.
  void reset(std::uint64_t seed);
  std::uint32_t sequence() const { return sequence_; }
  std::uint64_t steps() const { return steps_; }

  // A drive block carrying sequence + 1 steps the plant; one carrying the
  // present sequence repeats the last accepted write (the client did not see
  // the step, e.g. its read failed) and is acknowledged without a step.
  bool drive_steps(std::uint32_t sequence) const { return sequence == sequence_ + 1; }
  bool drive_repeats(std::uint32_t sequence) const { return sequence == sequence_; }
  // The drive block in the holding registers was just written: step once.
  void step_from_drive_block();

  // Flips bits in the served sensor values (not the checksum); again to undo.
  void toggle_corruption();

  const sim::SimInstrument& instrument() const { return *instrument_; }
  const hal::RegisterMap& map() const { return map_; }

 private:
  void publish_sensors(std::uint16_t status);

  hal::RegisterMap map_;
  sim::InstrumentParams params_;
  double step_period_s_;
  std::unique_ptr<sim::SimInstrument> instrument_;
  std::uint32_t sequence_ = 0;
  std::uint64_t steps_ = 0;  // of this session
  modbus_mapping_t* mapping_ = nullptr;
};

}  // namespace tribo::bench
