#include "tests/modbus/modbus_support.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "daemon/daemon_config.h"
#include "proto/text_format_file.h"
#include "sim/capacitive_sensor.h"
#include "sim/instrument_params.h"

namespace tribo::testing {

std::string modbus_config_path() { return std::string(TRIBO_SOURCE_DIR) + "/config/tribod-modbus.textproto"; }
std::string bench_config_path() { return std::string(TRIBO_SOURCE_DIR) + "/config/tribo-bench.textproto"; }
std::string tribo_bench_path() { return TRIBO_BENCH_PATH; }

namespace {

v1::DaemonConfig load(const std::string& path) {
  v1::DaemonConfig config;
  if (auto e = daemon::load_daemon_config(path, config)) throw std::runtime_error(*e);
  return config;
}

}  // namespace

v1::DaemonConfig modbus_daemon_config() { return load(modbus_config_path()); }
v1::DaemonConfig sim_daemon_config() { return load(std::string(TRIBO_SOURCE_DIR) + "/config/tribod.textproto"); }

void write_text_proto(const std::filesystem::path& path, const google::protobuf::Message& message) {
  std::ofstream(path) << wire::to_text_proto(message);
}

BenchProcess::BenchProcess(const std::filesystem::path& bench_config) {
  int out[2];
  if (pipe(out) != 0) throw std::runtime_error("pipe failed");
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ == 0) {
    // Never outlive the test.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(1);
    dup2(out[1], STDOUT_FILENO);
    if (std::getenv("TRIBO_TEST_BENCH_LOG") == nullptr) {
      const int devnull = open("/dev/null", O_WRONLY);
      dup2(devnull, STDERR_FILENO);
    }
    close(out[0]);
    const std::string path = tribo_bench_path(), config = bench_config.string();
    execl(path.c_str(), path.c_str(), "--config", config.c_str(), "--port", "0", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(out[1]);
  // The first line says where it listens: "tribo-bench listening on 127.0.0.1:PORT".
  FILE* stream = fdopen(out[0], "r");
  char line[256] = {0};
  const bool got = std::fgets(line, sizeof line, stream) != nullptr;
  std::fclose(stream);
  // Or, serving RTU, the device: "tribo-bench listening on /dev/pts/N".
  if (got && std::strstr(line, "listening on /") != nullptr) return;
  unsigned port = 0;
  const char* colon = got ? std::strrchr(line, ':') : nullptr;
  if (colon == nullptr || std::sscanf(colon + 1, "%u", &port) != 1 || port == 0) {
    terminate();
    throw std::runtime_error("tribo-bench did not start: '" + std::string(line) + "'");
  }
  port_ = static_cast<std::uint16_t>(port);
}

int BenchProcess::terminate() {
  if (pid_ <= 0) return 0;
  kill(pid_, SIGTERM);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return status;
}

BenchProcess::~BenchProcess() { terminate(); }

std::filesystem::path write_bench_config(const std::filesystem::path& dir, const v1::DaemonConfig& modbus_config,
                                         const std::vector<v1::BenchFault>& faults, const v1::ModbusRtuLink* rtu,
                                         const v1::DaemonConfig* physics_config) {
  write_text_proto(dir / "tribod-modbus.textproto", modbus_config);
  v1::BenchConfig bench;
  bench.set_bind_address("127.0.0.1");
  bench.set_port(0);
  bench.set_modbus_config_file("tribod-modbus.textproto");
  if (physics_config != nullptr) {
    write_text_proto(dir / "physics.textproto", *physics_config);
    bench.set_physics_config_file((dir / "physics.textproto").string());
  } else {
    bench.set_physics_config_file(std::string(TRIBO_SOURCE_DIR) + "/config/tribod.textproto");
  }
  for (const auto& f : faults) *bench.add_faults() = f;
  if (rtu != nullptr) *bench.mutable_rtu() = *rtu;
  const auto path = dir / "tribo-bench.textproto";
  write_text_proto(path, bench);
  return path;
}

v1::DaemonConfig with_port(v1::DaemonConfig config, std::uint16_t port) {
  config.mutable_modbus()->mutable_tcp()->set_port(port);
  return config;
}

double lateral_position_step_m(const v1::DaemonConfig& sim_config, double x) {
  const sim::CapacitiveSensingParams s = sim::instrument_params_from_config(sim_config.sim()).lateral_sensing;
  const sim::Adc adc(s.adc_bits, s.adc_full_scale_v);
  if (adc.bits == 0) throw std::runtime_error("the simulated lateral position has no converter (adc_bits 0)");
  const double gain = s.excitation_voltage_v / s.feedback_capacitance_f;
  const double v = gain * sim::differential_capacitance_f(s.plates, x);
  return sim::position_from_voltage_m(s.calibrated, gain, v + adc.step_v / 2) -
         sim::position_from_voltage_m(s.calibrated, gain, v - adc.step_v / 2);
}

v1::Protocol protocol_from_text(const std::string& text, const std::string& name) {
  v1::Protocol p;
  if (const auto error = wire::parse_text_proto(text, name, p)) throw std::runtime_error(*error);
  return p;
}

v1::Protocol short_scratch() {
  return protocol_from_text(R"(
    name: "standard-scratch-short"
    acquisition_rate_hz: 1000
    segments { name: "approach" duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { name: "load" duration_s: 0.5 normal { end_uN: 1000 } lateral { end_um: 2 } }
    segments { name: "scratch" duration_s: 4 normal { end_uN: 1000 } lateral { end_um: 4 } }
    segments { name: "unload" duration_s: 0.5 normal { end_uN: 0 } lateral { end_um: 4 } }
  )", "short_scratch");
}

}  // namespace tribo::testing
