// The numbers of the register map: register formats, the capacitive sensor's
// linearisation and the electrostatic drive (dissertation §5.1.1-5.1.2), the checksum.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "hal/modbus_scaling.h"

namespace tribo::hal {
namespace {

// Dissertation §5.1.1: d = 85 µm, A = 1 cm^2; V0 / Cf = 2.5 V / 1 pF.
const CapacitiveSensorParams kSensor{8.854e-12, 1e-4, 85e-6, 2.5, 1e-12};
const ElectrostaticParams kActuator{8.854e-12, 1e-4, 85e-6};

TEST(CapacitiveSensor, VoltageIsPhysicsEquation) {
  // dC = 2 eps A x / (d^2 - x^2), dV = (V0 / Cf) dC, evaluated independently.
  for (double x : {-40e-6, -15e-6, -1e-9, 0.0, 2e-6, 15e-6, 60e-6}) {
    const double d = 85e-6, eps_a = 8.854e-12 * 1e-4;
    const double delta_c = 2 * eps_a * x / (d * d - x * x);
    EXPECT_DOUBLE_EQ(capacitive_sense_voltage(kSensor, x), 2.5 / 1e-12 * delta_c) << x;
  }
  // Linear near zero: 0.61 V/µm; nonlinear towards the plates (more volts per µm).
  EXPECT_NEAR(capacitive_sense_voltage(kSensor, 1e-9) / 1e-9, 6.1273e5, 1e2);
  EXPECT_GT(capacitive_sense_voltage(kSensor, 60e-6), 4 * capacitive_sense_voltage(kSensor, 15e-6));
}

TEST(CapacitiveSensor, LinearisationInvertsTheSensorEverywhereInsideTheGap) {
  for (double x = -80e-6; x <= 80e-6; x += 0.37e-6) {
    const double v = capacitive_sense_voltage(kSensor, x);
    EXPECT_NEAR(capacitive_position(kSensor, v), x, 1e-12 * 85e-6) << x;
  }
  EXPECT_EQ(capacitive_position(kSensor, 0.0), 0.0);
  // Huge voltages stay inside the gap: the plates are the limit.
  EXPECT_LT(std::fabs(capacitive_position(kSensor, 1e6)), 85e-6);
  EXPECT_GT(capacitive_position(kSensor, 1e6), 84.9e-6);
}

TEST(CapacitiveSensor, LinearisationMattersAtTheTravelLimit) {
  // Reading the 15 µm voltage with the small-signal slope would be 3 % off:
  // the linearisation is not cosmetic.
  const double v = capacitive_sense_voltage(kSensor, 15e-6);
  const double slope = capacitive_sense_voltage(kSensor, 1e-12) / 1e-12;
  EXPECT_GT(v / slope, 15e-6 * 1.03);
  EXPECT_NEAR(capacitive_position(kSensor, v), 15e-6, 1e-17);
}

TEST(ElectrostaticDrive, ForceIsPhysicsEquationAndVoltageInvertsIt) {
  const double eps_a = 8.854e-12 * 1e-4;
  for (double x : {-15e-6, 0.0, 2e-6, 15e-6}) {
    for (double f : {-5e-3, -1e-6, 0.0, 3e-9, 1e-3, 10e-3}) {
      const double v = electrostatic_voltage(kActuator, f, x);
      const double gap = f >= 0 ? 85e-6 - x : 85e-6 + x;  // the pulling plate's side
      EXPECT_NEAR(std::fabs(v), gap * std::sqrt(2 * std::fabs(f) / eps_a), 1e-12) << f << " " << x;
      EXPECT_EQ(std::signbit(v), std::signbit(f));
      EXPECT_NEAR(electrostatic_force(kActuator, v, x), f, 1e-15 + 1e-13 * std::fabs(f)) << f << " " << x;
    }
  }
  // Dissertation §5.1.1 (eqs. 16-19): 1 mN at x = 0 takes about 128 V; a closer plate needs less.
  EXPECT_NEAR(electrostatic_voltage(kActuator, 1e-3, 0), 127.8, 0.1);
  EXPECT_LT(electrostatic_voltage(kActuator, 1e-3, 10e-6), electrostatic_voltage(kActuator, 1e-3, 0));
}

TEST(RegisterFormat, RoundTripsEveryTypeInBothWordOrders) {
  for (bool low_first : {false, true}) {
    std::uint16_t regs[2] = {0, 0};
    const struct {
      RegisterType type;
      double value;
    } cases[] = {{RegisterType::kInt16, -12345}, {RegisterType::kUint16, 54321},
                 {RegisterType::kInt32, -2000000001}, {RegisterType::kUint32, 4000000001.0},
                 {RegisterType::kFloat32, 1.5e-3}};
    for (const auto& c : cases) {
      const RegisterFormat f{c.type, low_first};
      EXPECT_TRUE(counts_to_registers(c.value, f, regs));
      const double back = counts_from_registers(regs, f);
      EXPECT_NEAR(back, c.value, c.type == RegisterType::kFloat32 ? 1e-10 : 0.0);
    }
  }
  // Word order: 0x12345678 high word first is {0x1234, 0x5678}.
  std::uint16_t regs[2];
  counts_to_registers(0x12345678, {RegisterType::kUint32, false}, regs);
  EXPECT_EQ(regs[0], 0x1234);
  EXPECT_EQ(regs[1], 0x5678);
  counts_to_registers(0x12345678, {RegisterType::kUint32, true}, regs);
  EXPECT_EQ(regs[0], 0x5678);
  EXPECT_EQ(regs[1], 0x1234);
  // Rounds to the nearest count.
  counts_to_registers(-2.5000001, {RegisterType::kInt32, false}, regs);
  EXPECT_EQ(counts_from_registers(regs, {RegisterType::kInt32, false}), -3);
}

TEST(RegisterFormat, ClampsOutOfRangeAndReportsTheRail) {
  std::uint16_t regs[2];
  const RegisterFormat i16{RegisterType::kInt16, false};
  EXPECT_FALSE(counts_to_registers(40000, i16, regs));
  EXPECT_EQ(counts_from_registers(regs, i16), 32767);
  EXPECT_TRUE(counts_at_rail(32767, RegisterType::kInt16));
  EXPECT_TRUE(counts_at_rail(-32768, RegisterType::kInt16));
  EXPECT_FALSE(counts_at_rail(32766, RegisterType::kInt16));
  EXPECT_FALSE(counts_to_registers(std::nan(""), {RegisterType::kInt32, false}, regs));
  EXPECT_TRUE(counts_at_rail(2147483647.0, RegisterType::kInt32));
  EXPECT_FALSE(counts_at_rail(1e30, RegisterType::kFloat32));
}

TEST(RegisterFormat, SixtyFourBitSeed) {
  std::uint16_t regs[4];
  uint64_to_registers(0x0123456789ABCDEFull, false, regs);
  EXPECT_EQ(regs[0], 0x0123);
  EXPECT_EQ(regs[3], 0xCDEF);
  EXPECT_EQ(uint64_from_registers(regs, false), 0x0123456789ABCDEFull);
  uint64_to_registers(0x0123456789ABCDEFull, true, regs);
  EXPECT_EQ(regs[0], 0xCDEF);
  EXPECT_EQ(uint64_from_registers(regs, true), 0x0123456789ABCDEFull);
}

TEST(Checksum, IsCrc16Modbus) {
  // The textbook Modbus RTU request 01 03 00 00 00 0A carries CRC C5 CD (low byte first).
  const std::uint16_t regs[] = {0x0103, 0x0000, 0x000A, 0xFFFF};
  EXPECT_EQ(crc16_of_registers(regs, 4, 3), 0xCDC5);
  // The skipped register does not count.
  const std::uint16_t other[] = {0x0103, 0x0000, 0x000A, 0x1234};
  EXPECT_EQ(crc16_of_registers(other, 4, 3), 0xCDC5);
}

}  // namespace
}  // namespace tribo::hal
