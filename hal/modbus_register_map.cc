#include "hal/modbus_register_map.h"

#include <cmath>
#include <sstream>
#include <vector>

namespace tribo::hal {

namespace {

RegisterType register_type(v1::RegisterType type) {
  switch (type) {
    case v1::INT16: return RegisterType::kInt16;
    case v1::UINT16: return RegisterType::kUint16;
    case v1::UINT32: return RegisterType::kUint32;
    case v1::FLOAT32: return RegisterType::kFloat32;
    default: return RegisterType::kInt32;
  }
}

RegisterTable register_table(v1::RegisterTable table) {
  return table == v1::HOLDING_REGISTERS ? RegisterTable::kHolding : RegisterTable::kInput;
}

CapacitiveSensorParams capacitive_params(const v1::CapacitiveSensor& c) {
  return {c.permittivity_f_per_m(), c.plate_area_m2(), c.plate_gap_m(), c.excitation_v(),
          c.feedback_capacitance_f()};
}

ElectrostaticParams electrostatic_params(const v1::ElectrostaticActuator& e) {
  return {e.permittivity_f_per_m(), e.plate_area_m2(), e.plate_gap_m()};
}

SensorChannelMap sensor_channel(const v1::SensorChannel& c, unsigned block_address, bool low_word_first) {
  SensorChannelMap m;
  m.offset = c.address() - block_address;
  m.format = {register_type(c.type()), low_word_first};
  m.volts_per_count = c.volts_per_count();
  m.zero_offset_v = c.zero_offset_v();
  m.capacitive = c.has_capacitive();
  if (m.capacitive) {
    m.sensor = capacitive_params(c.capacitive());
  } else {
    m.si_per_volt = c.linear().si_per_volt();
  }
  return m;
}

DriveChannelMap drive_channel(const v1::DriveChannel& c, unsigned block_address, bool low_word_first) {
  DriveChannelMap m;
  m.offset = c.address() - block_address;
  m.format = {register_type(c.type()), low_word_first};
  m.volts_per_count = c.volts_per_count();
  m.electrostatic = c.has_electrostatic();
  if (m.electrostatic) {
    m.actuator = electrostatic_params(c.electrostatic());
  } else {
    m.si_per_volt = c.linear().si_per_volt();
  }
  return m;
}

// ------------------------------------------------------------ validation

std::string num(double value) {
  std::ostringstream s;
  s << value;
  return s.str();
}

bool positive(double v) { return std::isfinite(v) && v > 0; }

// Registers claimed by the map's fields, to find overlaps and strays.
struct Claim {
  std::string field;
  RegisterTable table;
  unsigned first;
  unsigned width;
};

std::optional<std::string> check_claims(const std::vector<Claim>& claims) {
  for (std::size_t i = 0; i < claims.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      const Claim& a = claims[i];
      const Claim& b = claims[j];
      if (a.table != b.table) continue;
      if (a.first < b.first + b.width && b.first < a.first + a.width) {
        return a.field + " = " + std::to_string(a.first) + ": overlaps " + b.field + " (registers " +
               std::to_string(b.first) + ".." + std::to_string(b.first + b.width - 1) + ")";
      }
    }
  }
  return std::nullopt;
}

std::optional<std::string> check_inside(const std::string& field, unsigned address, unsigned width,
                                        unsigned block_address, unsigned block_count,
                                        const std::string& block) {
  if (address >= block_address && address + width <= block_address + block_count) return std::nullopt;
  return field + " = " + std::to_string(address) + ": the value (" + std::to_string(width) +
         " registers) must lie inside " + block + " [" + std::to_string(block_address) + ", " +
         std::to_string(block_address + block_count) + ")";
}

std::optional<std::string> check_type(const std::string& at, v1::RegisterType type) {
  if (type == v1::REGISTER_TYPE_UNSPECIFIED || !v1::RegisterType_IsValid(type)) {
    return at + ".type: not set (INT16, UINT16, INT32, UINT32 or FLOAT32)";
  }
  return std::nullopt;
}

std::optional<std::string> check_capacitive(const std::string& at, const v1::CapacitiveSensor& c) {
  for (auto [name, value] : {std::pair{"permittivity_f_per_m", c.permittivity_f_per_m()},
                             std::pair{"plate_area_m2", c.plate_area_m2()},
                             std::pair{"plate_gap_m", c.plate_gap_m()},
                             std::pair{"excitation_v", c.excitation_v()},
                             std::pair{"feedback_capacitance_f", c.feedback_capacitance_f()}}) {
    if (!positive(value)) return at + ".capacitive." + name + " = " + num(value) + ": must be > 0";
  }
  return std::nullopt;
}

std::optional<std::string> check_electrostatic(const std::string& at, const v1::ElectrostaticActuator& e) {
  for (auto [name, value] : {std::pair{"permittivity_f_per_m", e.permittivity_f_per_m()},
                             std::pair{"plate_area_m2", e.plate_area_m2()},
                             std::pair{"plate_gap_m", e.plate_gap_m()}}) {
    if (!positive(value)) return at + ".electrostatic." + name + " = " + num(value) + ": must be > 0";
  }
  return std::nullopt;
}

// The volts an integer register can carry; FLOAT32 carries any.
bool volts_representable(RegisterType type, double volts_per_count, double volts) {
  if (type == RegisterType::kFloat32) return std::isfinite(volts);
  return !counts_at_rail(std::nearbyint(volts / volts_per_count), type);
}

std::optional<std::string> check_sensor_channel(const std::string& at, const v1::SensorChannel& c,
                                                double must_carry, const std::string& limit_name) {
  if (auto e = check_type(at, c.type())) return e;
  if (!positive(c.volts_per_count())) {
    return at + ".volts_per_count = " + num(c.volts_per_count()) + ": must be > 0";
  }
  if (!std::isfinite(c.zero_offset_v())) return at + ".zero_offset_v = " + num(c.zero_offset_v()) + ": must be finite";
  double volts_needed = 0;
  switch (c.scale_case()) {
    case v1::SensorChannel::kLinear:
      if (!std::isfinite(c.linear().si_per_volt()) || c.linear().si_per_volt() == 0) {
        return at + ".linear.si_per_volt = " + num(c.linear().si_per_volt()) + ": must be finite and non-zero";
      }
      volts_needed = must_carry / std::fabs(c.linear().si_per_volt());
      break;
    case v1::SensorChannel::kCapacitive: {
      if (auto e = check_capacitive(at, c.capacitive())) return e;
      if (must_carry >= c.capacitive().plate_gap_m()) {
        return at + ".capacitive.plate_gap_m = " + num(c.capacitive().plate_gap_m()) +
               ": must exceed " + limit_name + " = " + num(must_carry);
      }
      volts_needed = capacitive_sense_voltage(capacitive_params(c.capacitive()), must_carry);
      break;
    }
    case v1::SensorChannel::SCALE_NOT_SET:
      return at + ": no scale (set linear { ... } or capacitive { ... })";
  }
  const RegisterType type = register_type(c.type());
  for (double sign : {1.0, -1.0}) {
    const double volts = c.zero_offset_v() + sign * volts_needed;
    if (!volts_representable(type, c.volts_per_count(), volts)) {
      return at + ": full scale too small: " + limit_name + " = " + num(sign * must_carry) + " needs " +
             num(volts) + " V, beyond the register's range at volts_per_count = " + num(c.volts_per_count());
    }
  }
  return std::nullopt;
}

std::optional<std::string> check_drive_channel(const std::string& at, const v1::DriveChannel& c,
                                               double must_force_n, double worst_gap_extra_m,
                                               const std::string& limit_name) {
  if (auto e = check_type(at, c.type())) return e;
  if (!positive(c.volts_per_count())) {
    return at + ".volts_per_count = " + num(c.volts_per_count()) + ": must be > 0";
  }
  double volts_needed = 0;
  switch (c.scale_case()) {
    case v1::DriveChannel::kLinear:
      if (!std::isfinite(c.linear().si_per_volt()) || c.linear().si_per_volt() == 0) {
        return at + ".linear.si_per_volt = " + num(c.linear().si_per_volt()) + ": must be finite and non-zero";
      }
      volts_needed = must_force_n / std::fabs(c.linear().si_per_volt());
      break;
    case v1::DriveChannel::kElectrostatic:
      if (auto e = check_electrostatic(at, c.electrostatic())) return e;
      if (worst_gap_extra_m >= c.electrostatic().plate_gap_m()) {
        return at + ".electrostatic.plate_gap_m = " + num(c.electrostatic().plate_gap_m()) +
               ": must exceed limits.max_lateral_travel_m = " + num(worst_gap_extra_m);
      }
      // The widest gap (the tip at the far end of its travel) needs the most voltage.
      volts_needed = electrostatic_voltage(electrostatic_params(c.electrostatic()), must_force_n,
                                           -worst_gap_extra_m);
      break;
    case v1::DriveChannel::SCALE_NOT_SET:
      return at + ": no scale (set linear { ... } or electrostatic { ... })";
  }
  const RegisterType type = register_type(c.type());
  for (double sign : {1.0, -1.0}) {
    if (!volts_representable(type, c.volts_per_count(), sign * volts_needed)) {
      return at + ": full scale too small: " + limit_name + " = " + num(sign * must_force_n) + " needs " +
             num(sign * volts_needed) + " V, beyond the register's range at volts_per_count = " +
             num(c.volts_per_count());
    }
  }
  return std::nullopt;
}

unsigned width_of(v1::RegisterType type) { return static_cast<unsigned>(register_width(register_type(type))); }

std::optional<std::string> check_block_extent(const std::string& at, unsigned address, unsigned count,
                                              unsigned max_count) {
  if (count < 1 || count > max_count) {
    return at + ".count = " + std::to_string(count) + ": must be in [1, " + std::to_string(max_count) +
           "] (one Modbus transaction)";
  }
  if (address + count > 65536) {
    return at + ".address = " + std::to_string(address) + ": the block runs past register 65535";
  }
  return std::nullopt;
}

}  // namespace

RegisterMap register_map_from_config(const v1::ModbusRegisterMap& c) {
  RegisterMap m;
  m.low_word_first = c.word_order() == v1::LOW_WORD_FIRST;
  const auto& s = c.sensors();
  m.sensors.table = register_table(s.table());
  m.sensors.address = s.address();
  m.sensors.count = s.count();
  m.sensors.sequence_offset = s.sequence_address() - s.address();
  m.sensors.status_offset = s.status_address() - s.address();
  if (s.has_checksum_address()) m.sensors.checksum_offset = s.checksum_address() - s.address();
  m.sensors.lateral_position = sensor_channel(s.lateral_position(), s.address(), m.low_word_first);
  m.sensors.lateral_force = sensor_channel(s.lateral_force(), s.address(), m.low_word_first);
  m.sensors.normal_force = sensor_channel(s.normal_force(), s.address(), m.low_word_first);
  m.sensors.normal_displacement = sensor_channel(s.normal_displacement(), s.address(), m.low_word_first);
  const auto& d = c.drive();
  m.drive.address = d.address();
  m.drive.count = d.count();
  m.drive.sequence_offset = d.sequence_address() - d.address();
  m.drive.normal_force = drive_channel(d.normal_force(), d.address(), m.low_word_first);
  m.drive.lateral_force = drive_channel(d.lateral_force(), d.address(), m.low_word_first);
  if (c.has_identity()) m.identity = IdentityBlockMap{register_table(c.identity().table()), c.identity().address()};
  if (c.has_session()) m.session_address = c.session().address();
  return m;
}

std::optional<std::string> validate_register_map(const v1::ModbusRegisterMap& c, const MapRequirements& needs,
                                                 const std::string& prefix) {
  if (!v1::WordOrder_IsValid(c.word_order())) return prefix + ".word_order: unknown value";
  const auto& s = c.sensors();
  const std::string sp = prefix + ".sensors";
  if (!c.has_sensors()) return sp + ": missing";
  if (s.table() == v1::REGISTER_TABLE_UNSPECIFIED || !v1::RegisterTable_IsValid(s.table())) {
    return sp + ".table: not set (INPUT_REGISTERS or HOLDING_REGISTERS)";
  }
  if (auto e = check_block_extent(sp, s.address(), s.count(), 125)) return e;
  if (auto e = check_sensor_channel(sp + ".lateral_position", s.lateral_position(), needs.max_lateral_travel_m,
                                    "limits.max_lateral_travel_m")) return e;
  if (auto e = check_sensor_channel(sp + ".lateral_force", s.lateral_force(), needs.max_lateral_force_n,
                                    "limits.max_lateral_force_n")) return e;
  if (auto e = check_sensor_channel(sp + ".normal_force", s.normal_force(), needs.max_normal_force_n,
                                    "limits.max_normal_force_n")) return e;
  if (auto e = check_sensor_channel(sp + ".normal_displacement", s.normal_displacement(), 0,
                                    "zero displacement")) return e;

  const RegisterTable sensor_table = register_table(s.table());
  std::vector<Claim> claims = {
      {sp + ".sequence_address", sensor_table, s.sequence_address(), 2},
      {sp + ".status_address", sensor_table, s.status_address(), 1},
      {sp + ".lateral_position.address", sensor_table, s.lateral_position().address(),
       width_of(s.lateral_position().type())},
      {sp + ".lateral_force.address", sensor_table, s.lateral_force().address(), width_of(s.lateral_force().type())},
      {sp + ".normal_force.address", sensor_table, s.normal_force().address(), width_of(s.normal_force().type())},
      {sp + ".normal_displacement.address", sensor_table, s.normal_displacement().address(),
       width_of(s.normal_displacement().type())},
  };
  if (s.has_checksum_address()) claims.push_back({sp + ".checksum_address", sensor_table, s.checksum_address(), 1});
  for (const Claim& claim : claims) {
    if (auto e = check_inside(claim.field, claim.first, claim.width, s.address(), s.count(), sp)) return e;
  }

  const auto& d = c.drive();
  const std::string dp = prefix + ".drive";
  if (!c.has_drive()) return dp + ": missing";
  if (auto e = check_block_extent(dp, d.address(), d.count(), 123)) return e;
  if (auto e = check_drive_channel(dp + ".lateral_force", d.lateral_force(), needs.max_lateral_drive_n,
                                   needs.max_lateral_travel_m, "controller.lateral_displacement output limit"))
    return e;
  if (auto e = check_drive_channel(dp + ".normal_force", d.normal_force(), needs.max_normal_force_n, 0,
                                   "limits.max_normal_force_n")) return e;
  const std::size_t first_drive_claim = claims.size();
  claims.push_back({dp + ".sequence_address", RegisterTable::kHolding, d.sequence_address(), 2});
  claims.push_back({dp + ".normal_force.address", RegisterTable::kHolding, d.normal_force().address(),
                    width_of(d.normal_force().type())});
  claims.push_back({dp + ".lateral_force.address", RegisterTable::kHolding, d.lateral_force().address(),
                    width_of(d.lateral_force().type())});
  for (std::size_t i = first_drive_claim; i < claims.size(); ++i) {
    const Claim& claim = claims[i];
    if (auto e = check_inside(claim.field, claim.first, claim.width, d.address(), d.count(), dp)) return e;
  }
  if (auto e = check_claims(claims)) return e;

  // Whole blocks must not overlap either: a drive write must not land in the
  // sensor block, nor a session reset in the drive block.
  std::vector<Claim> blocks = {{sp + ".address", sensor_table, s.address(), s.count()},
                               {dp + ".address", RegisterTable::kHolding, d.address(), d.count()}};
  if (c.has_identity()) {
    const std::string ip = prefix + ".identity";
    if (c.identity().table() == v1::REGISTER_TABLE_UNSPECIFIED || !v1::RegisterTable_IsValid(c.identity().table())) {
      return ip + ".table: not set (INPUT_REGISTERS or HOLDING_REGISTERS)";
    }
    if (auto e = check_block_extent(ip, c.identity().address(), kIdentityRegisters, kIdentityRegisters)) return e;
    blocks.push_back({ip + ".address", register_table(c.identity().table()), c.identity().address(),
                      kIdentityRegisters});
  }
  if (c.has_session()) {
    const std::string ssp = prefix + ".session";
    if (auto e = check_block_extent(ssp, c.session().address(), kSessionRegisters, kSessionRegisters)) return e;
    blocks.push_back({ssp + ".address", RegisterTable::kHolding, c.session().address(), kSessionRegisters});
  }
  return check_claims(blocks);
}

double sensor_volts(const SensorChannelMap& c, double si) {
  const double v = c.capacitive ? capacitive_sense_voltage(c.sensor, si) : si / c.si_per_volt;
  return v + c.zero_offset_v;
}

double sensor_si(const SensorChannelMap& c, double volts) {
  const double v = volts - c.zero_offset_v;
  return c.capacitive ? capacitive_position(c.sensor, v) : v * c.si_per_volt;
}

double sensor_resolution(const SensorChannelMap& c, double si) {
  const double volts = sensor_volts(c, si);
  double step_v = c.volts_per_count;
  if (c.format.type == RegisterType::kFloat32) {
    const auto f = static_cast<float>(volts);
    step_v = static_cast<double>(std::nextafter(std::fabs(f), INFINITY) - std::fabs(f));
  }
  return std::fabs(sensor_si(c, volts + step_v) - sensor_si(c, volts));
}

}  // namespace tribo::hal
