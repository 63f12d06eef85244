// Encoding and decoding of the register map's blocks: the sensor block read
// each tick, the drive block written each tick, and the identity and session
// blocks. The backend decodes sensors and encodes drive; the emulator does the
// reverse with the same functions, so the two sides cannot drift apart.
#pragma once

#include <cstdint>

#include "hal/modbus_register_map.h"
#include "hal/transducer.h"

namespace tribo::hal {

struct SensorBlockValues {
  std::uint32_t sequence = 0;
  std::uint16_t status = 0;
  bool checksum_ok = true;    // true when the map has no checksum
  bool over_range = false;    // some channel sat at its converter's rail (that value is NaN)
  SensorFrame frame;          // SI; status_bits = status
};

// block: the map.sensors.count registers of one read.
SensorBlockValues decode_sensor_block(const RegisterMap& map, const std::uint16_t* block);
// Fills every field of the block (and its checksum); other registers are left alone.
void encode_sensor_block(const RegisterMap& map, std::uint32_t sequence, std::uint16_t status,
                         const SensorFrame& values, std::uint16_t* block);

// Positions that set the electrostatic actuators' gaps.
struct AxisPositions {
  double lateral_position_m = 0;
  double normal_displacement_m = 0;
};

// Returns false if a drive value had to be clamped to its register's range.
bool encode_drive_block(const RegisterMap& map, std::uint32_t sequence, const DriveCommand& command,
                        const AxisPositions& at, std::uint16_t* block);

struct DriveBlockValues {
  std::uint32_t sequence = 0;
  DriveCommand command;
};
DriveBlockValues decode_drive_block(const RegisterMap& map, const std::uint16_t* block, const AxisPositions& at);

struct IdentityValues {
  std::uint32_t magic = 0;
  std::uint16_t version = 0;
  std::uint32_t sample_period_ns = 0;
};
IdentityValues decode_identity_block(const RegisterMap& map, const std::uint16_t* block);
void encode_identity_block(const RegisterMap& map, const IdentityValues& values, std::uint16_t* block);

struct SessionValues {
  std::uint64_t seed = 0;
  std::uint16_t command = 0;
};
SessionValues decode_session_block(const RegisterMap& map, const std::uint16_t* block);
void encode_session_block(const RegisterMap& map, const SessionValues& values, std::uint16_t* block);

}  // namespace tribo::hal
