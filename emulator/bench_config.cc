#include "emulator/bench_config.h"

#include <sched.h>

#include <filesystem>

#include "daemon/daemon_config.h"
#include "daemon/loop_stability.h"
#include "emulator/fault_injector.h"
#include "hal/modbus_link.h"
#include "proto/text_format_file.h"

namespace tribo::bench {

std::optional<std::string> load_bench_setup(const std::string& path, BenchSetup& setup) {
  if (auto e = wire::load_text_proto_file(path, setup.bench)) return e;
  const v1::BenchConfig& b = setup.bench;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  const auto resolve = [&](const std::string& name) {
    const std::filesystem::path p(name);
    return (p.is_absolute() ? p : dir / p).string();
  };
  if (b.rtu().device().empty()) {
    if (b.bind_address().empty()) return path + ": bind_address is empty";
    if (b.port() > 65535) return path + ": port = " + std::to_string(b.port()) + ": must be in [0, 65535]";
  } else {
    v1::ModbusConfig probe;  // reuse the backend's RTU checks
    *probe.mutable_rtu() = b.rtu();
    probe.set_unit_id(1);
    probe.set_response_timeout_s(1);
    probe.set_byte_timeout_s(0.1);
    probe.set_max_consecutive_timeouts(1);
    probe.set_reconnect_backoff_min_s(1);
    probe.set_reconnect_backoff_max_s(1);
    if (auto e = hal::validate_link_config(probe, "rtu")) return path + ": " + *e;
  }
  if (b.modbus_config_file().empty()) return path + ": modbus_config_file is empty";
  if (b.physics_config_file().empty()) return path + ": physics_config_file is empty";
  if (auto e = validate_faults(b.faults())) return path + ": " + *e;
  if (b.realtime_priority() < 0 || b.realtime_priority() > 99) {
    return path + ": realtime_priority = " + std::to_string(b.realtime_priority()) + ": must be in [0, 99]";
  }
  if (b.has_cpu() && (b.cpu() < 0 || b.cpu() >= CPU_SETSIZE)) {
    return path + ": cpu = " + std::to_string(b.cpu()) + ": must be in [0, " + std::to_string(CPU_SETSIZE - 1) + "]";
  }

  const std::string modbus_path = resolve(b.modbus_config_file());
  if (auto e = daemon::load_daemon_config(modbus_path, setup.modbus)) return *e;
  if (!setup.modbus.has_modbus()) return modbus_path + ": backend is not modbus { ... } (modbus_config_file)";
  const std::string physics_path = resolve(b.physics_config_file());
  if (auto e = daemon::load_daemon_config(physics_path, setup.physics)) return *e;
  if (!setup.physics.has_sim()) return physics_path + ": backend is not sim { ... } (physics_config_file)";
  // The register map's loop drives this physics: its gains at its rate on
  // the emulated plant (the modbus config was checked on its own nominal
  // transducer constants when it loaded).
  if (auto e = daemon::check_loop_stability(setup.modbus.controller(), setup.physics)) {
    return modbus_path + " on the plant of " + physics_path + ": " + *e;
  }
  return std::nullopt;
}

}  // namespace tribo::bench
