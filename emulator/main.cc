// tribo-bench: the simulated instrument behind the Modbus register map, for
// hardware-in-the-loop runs of tribod without hardware and for the tests of
// the Modbus backend. docs/modbus.md ("The bench emulator") says how to use it.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "emulator/bench_config.h"
#include "daemon/loop_scheduling.h"
#include "emulator/bench_server.h"
#include "tribo/version.h"

namespace {


std::atomic<bool> g_stop{false};

extern "C" void on_signal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("tribo-bench"));
  spdlog::set_pattern("[%Y-%m-%dT%H:%M:%S.%eZ] [%n] [%l] %v", spdlog::pattern_time_type::utc);
  std::string config_path = "config/tribo-bench.textproto";
  std::optional<std::uint16_t> port;
  std::optional<std::string> bind;
  CLI::App app{"tribo-bench: the simulated instrument behind the Modbus register map", "tribo-bench"};
  app.set_version_flag("--version", std::string("tribo-bench ") + tribo::kSoftwareVersion);
  app.footer("On start it prints 'tribo-bench listening on ADDRESS:PORT' (or the RTU device) on stdout.");
  app.add_option("--config", config_path, "tribo.v1.BenchConfig, protobuf text format")->capture_default_str();
  app.add_option("--port", port, "Modbus TCP port; 0 picks a free one (overrides port)");
  app.add_option("--bind", bind, "address to listen on (overrides bind_address)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  tribo::bench::BenchSetup setup;
  if (auto error = tribo::bench::load_bench_setup(config_path, setup)) {
    std::cerr << "tribo-bench: " << *error << "\n";
    return 2;
  }
  if (port) setup.bench.set_port(static_cast<std::uint32_t>(*port));
  if (bind) setup.bench.set_bind_address(*bind);

  struct sigaction action {};
  action.sa_handler = on_signal;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  std::unique_ptr<tribo::bench::BenchServer> server;
  try {
    server = std::make_unique<tribo::bench::BenchServer>(setup);
  } catch (const std::exception& e) {
    std::cerr << "tribo-bench: " << e.what() << "\n";
    return 1;
  }
  // The server answers on this thread: real time as tribod's loop, if asked.
  const tribo::v1::BenchConfig& b = setup.bench;
  const auto scheduling = tribo::daemon::apply_loop_scheduling(
      b.realtime_priority(), true, b.has_cpu() ? std::optional<int>(b.cpu()) : std::nullopt);
  if (b.realtime_priority() > 0 || b.has_cpu()) spdlog::info("server thread: {}", scheduling.description);
  std::printf("tribo-bench listening on %s\n", server->endpoint().c_str());
  std::fflush(stdout);
  spdlog::info("serving {} (unit {}): plant step {} s, {} faults scheduled", server->endpoint(),
               setup.modbus.modbus().unit_id(), 1.0 / setup.modbus.controller().loop_rate_hz(),
               setup.bench.faults_size());
  server->run(g_stop);
  spdlog::info("stopped after {} plant steps in the last session", server->instrument().steps());
  return 0;
}
