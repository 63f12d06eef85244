// The Modbus register map (tribo.v1.ModbusRegisterMap) as plain structs, and
// its start-up validation. Offsets here are relative to their block's first
// register, so a block is decoded from the array one transaction returned.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "hal/modbus_scaling.h"
#include "tribo/v1/modbus_config.pb.h"

namespace tribo::hal {

inline constexpr std::uint32_t kIdentityMagic = 0x54524942;  // "TRIB"
inline constexpr std::uint16_t kRegisterMapVersion = 1;
inline constexpr unsigned kIdentityRegisters = 5;  // magic (2), version (1), period ns (2)
inline constexpr unsigned kSessionRegisters = 5;   // seed (4), command (1)
inline constexpr std::uint16_t kSessionReset = 1;

enum class RegisterTable { kHolding, kInput };

struct SensorChannelMap {
  unsigned offset = 0;
  RegisterFormat format;
  double volts_per_count = 1;
  double zero_offset_v = 0;
  bool capacitive = false;  // else linear
  double si_per_volt = 1;
  CapacitiveSensorParams sensor;
};

struct DriveChannelMap {
  unsigned offset = 0;
  RegisterFormat format;
  double volts_per_count = 1;
  bool electrostatic = false;  // else linear
  double si_per_volt = 1;
  ElectrostaticParams actuator;
};

struct SensorBlockMap {
  RegisterTable table = RegisterTable::kInput;
  unsigned address = 0;
  unsigned count = 0;
  unsigned sequence_offset = 0;
  unsigned status_offset = 0;
  std::optional<unsigned> checksum_offset;
  SensorChannelMap lateral_position;
  SensorChannelMap lateral_force;
  SensorChannelMap normal_force;
  SensorChannelMap normal_displacement;
};

struct DriveBlockMap {
  unsigned address = 0;
  unsigned count = 0;
  unsigned sequence_offset = 0;
  DriveChannelMap normal_force;
  DriveChannelMap lateral_force;
};

struct IdentityBlockMap {
  RegisterTable table = RegisterTable::kInput;
  unsigned address = 0;
};

struct RegisterMap {
  bool low_word_first = false;
  SensorBlockMap sensors;
  DriveBlockMap drive;
  std::optional<IdentityBlockMap> identity;
  std::optional<unsigned> session_address;  // holding registers
};

// Assumes a validated map.
RegisterMap register_map_from_config(const v1::ModbusRegisterMap& config);

// What the map must be able to carry: the instrument's limits and the
// controller's drive range.
struct MapRequirements {
  double max_lateral_travel_m = 0;
  double max_lateral_force_n = 0;
  double max_normal_force_n = 0;
  double max_lateral_drive_n = 0;
};

// nullopt when usable, else an error naming the entry (prefix + field path),
// the value and the rule it breaks.
std::optional<std::string> validate_register_map(const v1::ModbusRegisterMap& config,
                                                 const MapRequirements& needs,
                                                 const std::string& prefix = "modbus.register_map");

// A sensor channel's volts for an SI value and back (the linearisation).
double sensor_volts(const SensorChannelMap& channel, double si);
double sensor_si(const SensorChannelMap& channel, double volts);

// The quantisation step the register adds at an SI value (metres or newtons
// per count): part of the quantisation budget in docs/modbus.md.
double sensor_resolution(const SensorChannelMap& channel, double si);

}  // namespace tribo::hal
