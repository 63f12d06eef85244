// Shared set-up for the Modbus tests: the shipped configs, temporary config
// files, and tribo-bench started as a child process on an ephemeral port.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/modbus_config.pb.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo::testing {

std::string modbus_config_path();  // config/tribod-modbus.textproto
std::string bench_config_path();   // config/tribo-bench.textproto
std::string tribo_bench_path();

v1::DaemonConfig modbus_daemon_config();  // loaded and validated
v1::DaemonConfig sim_daemon_config();     // config/tribod.textproto

void write_text_proto(const std::filesystem::path& path, const google::protobuf::Message& message);

// tribo-bench with the given bench config, TCP on 127.0.0.1 and an ephemeral
// port (or RTU if the config says so: port() is then 0); stopped (SIGTERM,
// wait) when destroyed, and by the kernel if the test process dies first.
class BenchProcess {
 public:
  explicit BenchProcess(const std::filesystem::path& bench_config);
  ~BenchProcess();
  BenchProcess(const BenchProcess&) = delete;
  BenchProcess& operator=(const BenchProcess&) = delete;

  std::uint16_t port() const { return port_; }
  // Sends SIGTERM and waits; returns the waitpid status.
  int terminate();

 private:
  pid_t pid_ = -1;
  std::uint16_t port_ = 0;
};

// A bench config in dir that serves modbus_config (written next to it) with
// the physics of config/tribod.textproto (or of physics_config, written next
// to it, if given) and the given faults; over TCP, or over RTU on rtu's device if given.
std::filesystem::path write_bench_config(const std::filesystem::path& dir, const v1::DaemonConfig& modbus_config,
                                         const std::vector<v1::BenchFault>& faults = {},
                                         const v1::ModbusRtuLink* rtu = nullptr,
                                         const v1::DaemonConfig* physics_config = nullptr);

// The daemon config pointed at a bench on this port.
v1::DaemonConfig with_port(v1::DaemonConfig config, std::uint16_t port);

// One step of the simulated instrument's own lateral position converter at
// position x (sim/capacitive_sensor.h): the ADC's voltage step through the
// linearisation, dx = dV / (V0/Cf d(dC)/dx), so it grows with |x| as the
// differential capacitance steepens (2 pm at x = 0 in config/tribod.textproto).
// The converter the Modbus runs are compared against: "within quantisation".
double lateral_position_step_m(const v1::DaemonConfig& sim_config, double position_m);

// The standard scratch shortened for CI: same load (1000 µN) and speed
// (0.5 µm/s), segments cut to 1 + 0.5 + 4 + 0.5 s. A Modbus run is paced by
// the wall clock (the full 32 s protocol takes 35-60 s here); the lock-step
// handshake makes the result independent of the pace.
v1::Protocol short_scratch();
// A protocol from its text (protobuf text format); throws with the parser's
// message, naming `name`, if it does not parse.
v1::Protocol protocol_from_text(const std::string& text, const std::string& name);

}  // namespace tribo::testing
