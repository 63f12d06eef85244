#include "hal/modbus_scaling.h"

#include <bit>
#include <cmath>
#include <limits>

namespace tribo::hal {

namespace {

struct CountRange {
  double min;
  double max;
};

CountRange count_range(RegisterType type) {
  switch (type) {
    case RegisterType::kInt16: return {-32768.0, 32767.0};
    case RegisterType::kUint16: return {0.0, 65535.0};
    case RegisterType::kInt32: return {-2147483648.0, 2147483647.0};
    case RegisterType::kUint32: return {0.0, 4294967295.0};
    case RegisterType::kFloat32: break;
  }
  return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
}

}  // namespace

int register_width(RegisterType type) {
  return type == RegisterType::kInt16 || type == RegisterType::kUint16 ? 1 : 2;
}

std::uint32_t uint32_from_registers(const std::uint16_t* regs, bool low_word_first) {
  const std::uint32_t hi = low_word_first ? regs[1] : regs[0];
  const std::uint32_t lo = low_word_first ? regs[0] : regs[1];
  return hi << 16 | lo;
}

void uint32_to_registers(std::uint32_t value, bool low_word_first, std::uint16_t* regs) {
  const auto hi = static_cast<std::uint16_t>(value >> 16);
  const auto lo = static_cast<std::uint16_t>(value & 0xFFFF);
  regs[0] = low_word_first ? lo : hi;
  regs[1] = low_word_first ? hi : lo;
}

std::uint64_t uint64_from_registers(const std::uint16_t* regs, bool low_word_first) {
  std::uint64_t value = 0;
  for (int i = 0; i < 4; ++i) value = value << 16 | regs[low_word_first ? 3 - i : i];
  return value;
}

void uint64_to_registers(std::uint64_t value, bool low_word_first, std::uint16_t* regs) {
  for (int i = 0; i < 4; ++i) {
    regs[low_word_first ? i : 3 - i] = static_cast<std::uint16_t>(value >> (16 * i) & 0xFFFF);
  }
}

double counts_from_registers(const std::uint16_t* regs, RegisterFormat f) {
  switch (f.type) {
    case RegisterType::kInt16: return static_cast<std::int16_t>(regs[0]);
    case RegisterType::kUint16: return regs[0];
    case RegisterType::kInt32:
      return static_cast<std::int32_t>(uint32_from_registers(regs, f.low_word_first));
    case RegisterType::kUint32: return uint32_from_registers(regs, f.low_word_first);
    case RegisterType::kFloat32:
      return std::bit_cast<float>(uint32_from_registers(regs, f.low_word_first));
  }
  return std::numeric_limits<double>::quiet_NaN();
}

bool counts_at_rail(double counts, RegisterType type) {
  const CountRange r = count_range(type);
  return counts <= r.min || counts >= r.max;
}

bool counts_to_registers(double counts, RegisterFormat f, std::uint16_t* regs) {
  if (f.type == RegisterType::kFloat32) {
    uint32_to_registers(std::bit_cast<std::uint32_t>(static_cast<float>(counts)), f.low_word_first, regs);
    return std::isfinite(static_cast<float>(counts));
  }
  const CountRange r = count_range(f.type);
  const double rounded = std::nearbyint(counts);
  const double clamped = std::isnan(rounded) ? 0.0 : std::fmin(std::fmax(rounded, r.min), r.max);
  switch (f.type) {
    case RegisterType::kInt16:
      regs[0] = static_cast<std::uint16_t>(static_cast<std::int16_t>(clamped));
      break;
    case RegisterType::kUint16:
      regs[0] = static_cast<std::uint16_t>(clamped);
      break;
    case RegisterType::kInt32:
      uint32_to_registers(static_cast<std::uint32_t>(static_cast<std::int32_t>(clamped)),
                          f.low_word_first, regs);
      break;
    case RegisterType::kUint32:
      uint32_to_registers(static_cast<std::uint32_t>(clamped), f.low_word_first, regs);
      break;
    case RegisterType::kFloat32:
      break;
  }
  return clamped == rounded;
}

double capacitive_sense_voltage(const CapacitiveSensorParams& p, double x) {
  const double d = p.plate_gap_m;
  const double delta_c = 2.0 * p.permittivity_f_per_m * p.plate_area_m2 * x / (d * d - x * x);
  return p.excitation_v / p.feedback_capacitance_f * delta_c;
}

double capacitive_position(const CapacitiveSensorParams& p, double v) {
  const double delta_c = v * p.feedback_capacitance_f / p.excitation_v;
  const double eps_a = p.permittivity_f_per_m * p.plate_area_m2;
  const double d = p.plate_gap_m;
  return delta_c * d * d / (eps_a + std::hypot(eps_a, delta_c * d));
}

namespace {

double gap_towards(const ElectrostaticParams& p, bool positive_side, double x) {
  return positive_side ? p.plate_gap_m - x : p.plate_gap_m + x;
}

}  // namespace

double electrostatic_voltage(const ElectrostaticParams& p, double force_n, double x) {
  const double gap = gap_towards(p, force_n >= 0, x);
  const double magnitude =
      gap * std::sqrt(2.0 * std::fabs(force_n) / (p.permittivity_f_per_m * p.plate_area_m2));
  return std::copysign(magnitude, force_n);
}

double electrostatic_force(const ElectrostaticParams& p, double v, double x) {
  const double gap = gap_towards(p, v >= 0, x);
  const double magnitude = p.permittivity_f_per_m * p.plate_area_m2 * v * v / (2.0 * gap * gap);
  return std::copysign(magnitude, v);
}

std::uint16_t crc16_of_registers(const std::uint16_t* regs, std::size_t count, std::size_t skip) {
  std::uint16_t crc = 0xFFFF;
  const auto feed = [&crc](std::uint8_t byte) {
    crc ^= byte;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : static_cast<std::uint16_t>(crc >> 1);
    }
  };
  for (std::size_t i = 0; i < count; ++i) {
    if (i == skip) continue;
    feed(static_cast<std::uint8_t>(regs[i] >> 8));
    feed(static_cast<std::uint8_t>(regs[i] & 0xFF));
  }
  return crc;
}

}  // namespace tribo::hal
