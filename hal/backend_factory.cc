#include "hal/backend_factory.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "hal/modbus_link.h"
#include "hal/modbus_register_map.h"
#include "hal/modbus_transducer.h"
#include "hal/sim_transducer.h"
#include "sim/fault_injection.h"
#include "sim/instrument_params.h"

namespace tribo::hal {

namespace {

MapRequirements map_requirements(const v1::DaemonConfig& config) {
  const auto& limits = config.limits();
  const auto& lateral = config.controller().lateral_displacement();
  return MapRequirements{limits.max_lateral_travel_m(), limits.max_lateral_force_n(), limits.max_normal_force_n(),
                         std::max(std::fabs(lateral.output_min()), std::fabs(lateral.output_max()))};
}

// The fastest loop a Modbus RTU link can carry: a tick is four frames on the
// wire, read request (8 characters) and answer (5 + 2 per sensor register),
// drive write (9 + 2 per drive register) and answer (8), each followed by the
// 3.5 characters of silence that end an RTU frame; a character is a start
// bit, the data bits, the parity bit if any and the stop bits.
std::optional<std::string> check_rtu_loop_rate(const v1::DaemonConfig& config) {
  const v1::ModbusRtuLink& rtu = config.modbus().rtu();
  const auto& map = config.modbus().register_map();
  const double characters = 8 + (5 + 2.0 * map.sensors().count()) + (9 + 2.0 * map.drive().count()) + 8 + 4 * 3.5;
  const double bits_per_character = 1 + rtu.data_bits() + (rtu.parity() == "N" ? 0 : 1) + rtu.stop_bits();
  const double max_rate_hz = rtu.baud() / (characters * bits_per_character);
  const double rate_hz = config.controller().loop_rate_hz();
  if (rate_hz <= max_rate_hz) return std::nullopt;
  std::ostringstream limit;
  limit.precision(4);
  limit << max_rate_hz;
  std::ostringstream msg;
  msg << "controller.loop_rate_hz = " << rate_hz << ": above what modbus.rtu carries, at most " << limit.str()
      << " Hz (a tick is " << characters << " characters of " << bits_per_character
      << " bits at modbus.rtu.baud = " << rtu.baud() << "; docs/modbus.md)";
  return msg.str();
}

}  // namespace

std::unique_ptr<Transducer> make_transducer(const v1::DaemonConfig& config, std::uint64_t seed) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return std::make_unique<SimTransducer>(sim::instrument_params_from_config(config.sim()), seed,
                                             config.controller().loop_rate_hz(),
                                             config.controller().pace_to_wall_clock(),
                                             sim::fault_schedule_from_config(config.sim().faults()));
    case v1::DaemonConfig::kModbus:
      return std::make_unique<ModbusTransducer>(link_settings_from_config(config.modbus()),
                                                register_map_from_config(config.modbus().register_map()),
                                                config.controller().loop_rate_hz(), seed);
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return nullptr;
}

std::optional<std::string> validate_backend_config(const v1::DaemonConfig& config) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return sim::validate_sim_config(config.sim());
    case v1::DaemonConfig::kModbus:
      if (auto e = validate_link_config(config.modbus())) return e;
      if (!config.modbus().has_register_map()) return "modbus.register_map: missing";
      if (auto e = validate_register_map(config.modbus().register_map(), map_requirements(config))) return e;
      if (config.modbus().has_rtu()) return check_rtu_loop_rate(config);
      return std::nullopt;
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return "backend: no backend configured (set sim { ... } or modbus { ... })";
}

std::string backend_name(const v1::DaemonConfig& config) {
  switch (config.backend_case()) {
    case v1::DaemonConfig::kSim:
      return "sim";
    case v1::DaemonConfig::kModbus:
      return "modbus";
    case v1::DaemonConfig::BACKEND_NOT_SET:
      break;
  }
  return "none";
}

}  // namespace tribo::hal
