#include "emulator/emulated_instrument.h"

#include <modbus/modbus.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hal/modbus_blocks.h"
#include "hal/sim_transducer.h"

namespace tribo::bench {

namespace {

// Registers each table needs: up to the end of the last block in it.
int table_size(const hal::RegisterMap& m, hal::RegisterTable table) {
  unsigned end = 0;
  if (m.sensors.table == table) end = std::max(end, m.sensors.address + m.sensors.count);
  if (m.identity && m.identity->table == table) end = std::max(end, m.identity->address + hal::kIdentityRegisters);
  if (table == hal::RegisterTable::kHolding) {
    end = std::max(end, m.drive.address + m.drive.count);
    if (m.session_address) end = std::max(end, *m.session_address + hal::kSessionRegisters);
  }
  return static_cast<int>(end);
}

}  // namespace

EmulatedInstrument::EmulatedInstrument(const hal::RegisterMap& map, const sim::InstrumentParams& params,
                                       double step_period_s, std::uint64_t seed)
    : map_(map), params_(params), step_period_s_(step_period_s) {
  mapping_ = modbus_mapping_new(0, 0, table_size(map_, hal::RegisterTable::kHolding),
                                table_size(map_, hal::RegisterTable::kInput));
  if (mapping_ == nullptr) throw std::runtime_error("modbus_mapping_new failed");
  if (map_.identity) {
    const auto period_ns = static_cast<std::uint32_t>(std::llround(step_period_s_ * 1e9));
    hal::encode_identity_block(map_, {hal::kIdentityMagic, hal::kRegisterMapVersion, period_ns},
                               table(map_.identity->table) + map_.identity->address);
  }
  reset(seed);
}

EmulatedInstrument::~EmulatedInstrument() { modbus_mapping_free(mapping_); }

std::uint16_t* EmulatedInstrument::table(hal::RegisterTable t) {
  return t == hal::RegisterTable::kHolding ? mapping_->tab_registers : mapping_->tab_input_registers;
}

void EmulatedInstrument::reset(std::uint64_t seed) {
  instrument_ = std::make_unique<sim::SimInstrument>(params_, seed);
  sequence_ = 0;
  steps_ = 0;
  std::fill_n(table(hal::RegisterTable::kHolding) + map_.drive.address, map_.drive.count, 0);
  publish_sensors(0);
}

void EmulatedInstrument::step_from_drive_block() {
  const sim::InstrumentTruth& truth = instrument_->truth();
  // The actuators pull across the true gaps, at the start of the step.
  const hal::AxisPositions at{truth.lateral.position_m, truth.normal.displacement_m};
  const hal::DriveBlockValues drive =
      hal::decode_drive_block(map_, table(hal::RegisterTable::kHolding) + map_.drive.address, at);
  const sim::StepReport report = instrument_->step(
      sim::DriveInput{drive.command.normal_force_n, drive.command.lateral_force_n}, step_period_s_);
  ++sequence_;
  ++steps_;
  publish_sensors(static_cast<std::uint16_t>(hal::sensor_status_of(report)));
}

void EmulatedInstrument::publish_sensors(std::uint16_t status) {
  const sim::Measurement& m = instrument_->measurement();
  const hal::SensorFrame values{m.normal_force_n, m.normal_displacement_m, m.lateral_force_n, m.lateral_position_m,
                                status};
  hal::encode_sensor_block(map_, sequence_, status, values, table(map_.sensors.table) + map_.sensors.address);
}

void EmulatedInstrument::toggle_corruption() {
  std::uint16_t* block = table(map_.sensors.table) + map_.sensors.address;
  for (const hal::SensorChannelMap* c : {&map_.sensors.lateral_position, &map_.sensors.lateral_force,
                                         &map_.sensors.normal_force, &map_.sensors.normal_displacement}) {
    block[c->offset] ^= 0x0100;
  }
}

}  // namespace tribo::bench
