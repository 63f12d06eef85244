// The numbers of the Modbus register map: registers <-> counts, counts <->
// volts, and the transducer physics between volts and SI (dissertation §5.1.1-5.1.2, eqs. 16-25).
// Pure functions shared by the backend (hal/modbus_transducer.h) and the
// emulator (emulator/), so both sides of the map use one implementation.
#pragma once

#include <cstddef>
#include <cstdint>

namespace tribo::hal {

enum class RegisterType { kInt16, kUint16, kInt32, kUint32, kFloat32 };

int register_width(RegisterType type);  // 1 or 2 registers

struct RegisterFormat {
  RegisterType type = RegisterType::kInt32;
  bool low_word_first = false;
};

// The value of the registers at regs as a number of counts (FLOAT32: the float).
double counts_from_registers(const std::uint16_t* regs, RegisterFormat format);

// True when an integer reading sits at either end of its type's range: the
// converter was over range, the value is not a measurement.
bool counts_at_rail(double counts, RegisterType type);

// Rounds to the nearest count and stores it; out-of-range values are clamped
// to the type's range. Returns false if it clamped (or the value was NaN).
bool counts_to_registers(double counts, RegisterFormat format, std::uint16_t* regs);

// 32- and 64-bit unsigned values in the map's word order.
std::uint32_t uint32_from_registers(const std::uint16_t* regs, bool low_word_first);
void uint32_to_registers(std::uint32_t value, bool low_word_first, std::uint16_t* regs);
std::uint64_t uint64_from_registers(const std::uint16_t* regs, bool low_word_first);
void uint64_to_registers(std::uint64_t value, bool low_word_first, std::uint16_t* regs);

// Differential capacitive sensor, dissertation §5.1.2, eqs. 22-25:
//   dC = 2 eps A x / (d^2 - x^2),  dV = (V0 / Cf) dC.
struct CapacitiveSensorParams {
  double permittivity_f_per_m = 0;
  double plate_area_m2 = 0;
  double plate_gap_m = 0;
  double excitation_v = 0;
  double feedback_capacitance_f = 0;
};

double capacitive_sense_voltage(const CapacitiveSensorParams& p, double position_m);
// The inverse: x = dC d^2 / (eps A + sqrt((eps A)^2 + (dC d)^2)), the root of
// dC x^2 + 2 eps A x - dC d^2 = 0 with |x| < d, written without cancellation.
double capacitive_position(const CapacitiveSensorParams& p, double sense_voltage_v);

// Electrostatic actuator, dissertation §5.1.1, eqs. 16-19: F = eps A V^2 / (2 g^2), pulling
// towards the plate on the force's side (g = d - x for F > 0, d + x for F < 0).
// The sign of V selects the plate.
struct ElectrostaticParams {
  double permittivity_f_per_m = 0;
  double plate_area_m2 = 0;
  double plate_gap_m = 0;
};

double electrostatic_voltage(const ElectrostaticParams& p, double force_n, double position_m);
double electrostatic_force(const ElectrostaticParams& p, double voltage_v, double position_m);

// CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF) of the registers'
// big-endian bytes, skipping the register at index skip (the checksum's own).
std::uint16_t crc16_of_registers(const std::uint16_t* regs, std::size_t count, std::size_t skip);

}  // namespace tribo::hal
