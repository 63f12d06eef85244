#include "hal/modbus_blocks.h"

#include <cmath>
#include <limits>

namespace tribo::hal {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// NaN when the converter sat at its rail: an over-range reading is no measurement.
double decode_sensor(const SensorChannelMap& c, const std::uint16_t* block, bool& over_range) {
  const double counts = counts_from_registers(block + c.offset, c.format);
  if (c.format.type != RegisterType::kFloat32 && counts_at_rail(counts, c.format.type)) {
    over_range = true;
    return kNaN;
  }
  return sensor_si(c, counts * c.volts_per_count);
}

void encode_sensor(const SensorChannelMap& c, double si, std::uint16_t* block) {
  counts_to_registers(sensor_volts(c, si) / c.volts_per_count, c.format, block + c.offset);
}

double drive_volts(const DriveChannelMap& c, double force_n, double position_m) {
  return c.electrostatic ? electrostatic_voltage(c.actuator, force_n, position_m) : force_n / c.si_per_volt;
}

double drive_force(const DriveChannelMap& c, double volts, double position_m) {
  return c.electrostatic ? electrostatic_force(c.actuator, volts, position_m) : volts * c.si_per_volt;
}

}  // namespace

SensorBlockValues decode_sensor_block(const RegisterMap& map, const std::uint16_t* block) {
  const SensorBlockMap& s = map.sensors;
  SensorBlockValues v;
  v.sequence = uint32_from_registers(block + s.sequence_offset, map.low_word_first);
  v.status = block[s.status_offset];
  if (s.checksum_offset) {
    v.checksum_ok = crc16_of_registers(block, s.count, *s.checksum_offset) == block[*s.checksum_offset];
  }
  v.frame.lateral_position_m = decode_sensor(s.lateral_position, block, v.over_range);
  v.frame.lateral_force_n = decode_sensor(s.lateral_force, block, v.over_range);
  v.frame.normal_force_n = decode_sensor(s.normal_force, block, v.over_range);
  v.frame.normal_displacement_m = decode_sensor(s.normal_displacement, block, v.over_range);
  v.frame.status_bits = v.status;
  return v;
}

void encode_sensor_block(const RegisterMap& map, std::uint32_t sequence, std::uint16_t status,
                         const SensorFrame& values, std::uint16_t* block) {
  const SensorBlockMap& s = map.sensors;
  uint32_to_registers(sequence, map.low_word_first, block + s.sequence_offset);
  block[s.status_offset] = status;
  encode_sensor(s.lateral_position, values.lateral_position_m, block);
  encode_sensor(s.lateral_force, values.lateral_force_n, block);
  encode_sensor(s.normal_force, values.normal_force_n, block);
  encode_sensor(s.normal_displacement, values.normal_displacement_m, block);
  if (s.checksum_offset) block[*s.checksum_offset] = crc16_of_registers(block, s.count, *s.checksum_offset);
}

bool encode_drive_block(const RegisterMap& map, std::uint32_t sequence, const DriveCommand& command,
                        const AxisPositions& at, std::uint16_t* block) {
  const DriveBlockMap& d = map.drive;
  uint32_to_registers(sequence, map.low_word_first, block + d.sequence_offset);
  const double normal_v = drive_volts(d.normal_force, command.normal_force_n, at.normal_displacement_m);
  const double lateral_v = drive_volts(d.lateral_force, command.lateral_force_n, at.lateral_position_m);
  const bool normal_ok = counts_to_registers(normal_v / d.normal_force.volts_per_count, d.normal_force.format,
                                             block + d.normal_force.offset);
  const bool lateral_ok = counts_to_registers(lateral_v / d.lateral_force.volts_per_count,
                                              d.lateral_force.format, block + d.lateral_force.offset);
  return normal_ok && lateral_ok;
}

DriveBlockValues decode_drive_block(const RegisterMap& map, const std::uint16_t* block, const AxisPositions& at) {
  const DriveBlockMap& d = map.drive;
  DriveBlockValues v;
  v.sequence = uint32_from_registers(block + d.sequence_offset, map.low_word_first);
  const double normal_v =
      counts_from_registers(block + d.normal_force.offset, d.normal_force.format) * d.normal_force.volts_per_count;
  const double lateral_v = counts_from_registers(block + d.lateral_force.offset, d.lateral_force.format) *
                           d.lateral_force.volts_per_count;
  v.command.normal_force_n = drive_force(d.normal_force, normal_v, at.normal_displacement_m);
  v.command.lateral_force_n = drive_force(d.lateral_force, lateral_v, at.lateral_position_m);
  return v;
}

IdentityValues decode_identity_block(const RegisterMap& map, const std::uint16_t* block) {
  return IdentityValues{uint32_from_registers(block, map.low_word_first), block[2],
                        uint32_from_registers(block + 3, map.low_word_first)};
}

void encode_identity_block(const RegisterMap& map, const IdentityValues& v, std::uint16_t* block) {
  uint32_to_registers(v.magic, map.low_word_first, block);
  block[2] = v.version;
  uint32_to_registers(v.sample_period_ns, map.low_word_first, block + 3);
}

SessionValues decode_session_block(const RegisterMap& map, const std::uint16_t* block) {
  return SessionValues{uint64_from_registers(block, map.low_word_first), block[4]};
}

void encode_session_block(const RegisterMap& map, const SessionValues& v, std::uint16_t* block) {
  uint64_to_registers(v.seed, map.low_word_first, block);
  block[4] = v.command;
}

}  // namespace tribo::hal
