// tribo-bench's configuration: its own file (tribo.v1.BenchConfig: where to
// listen, which faults to inject) and the two tribod configs it names, one for
// the register map and loop rate, one for the physics. Everything is validated
// with the daemon's own checks, so the emulator serves exactly the map and the
// instrument that tribod would use.
#pragma once

#include <optional>
#include <string>

#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/modbus_config.pb.h"

namespace tribo::bench {

struct BenchSetup {
  v1::BenchConfig bench;
  v1::DaemonConfig modbus;   // backend modbus: register map, unit id, loop rate
  v1::DaemonConfig physics;  // backend sim: the emulated instrument
};

// Loads path and the files it names (relative to its directory); errors name
// the file and the field.
std::optional<std::string> load_bench_setup(const std::string& path, BenchSetup& setup);

}  // namespace tribo::bench
