// tribod: the tribo daemon. Loads its config, serves the socket API and runs
// protocols on the configured transducer backend.
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <thread>

#include <asio.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/daemon_config.h"
#include "daemon/instrument_service.h"
#include "hal/backend_factory.h"
#include "tribo/version.h"

namespace {

constexpr const char* kUsage =
    "usage: tribod [--config FILE] [--port N] [--bind ADDRESS] [--data-dir DIR]\n"
    "  --config FILE    daemon config, protobuf text format (default config/tribod.textproto)\n"
    "  --port N         TCP port to listen on; 0 picks a free one (overrides server.port)\n"
    "  --bind ADDRESS   address to listen on (overrides server.bind_address)\n"
    "  --data-dir DIR   where runs are recorded (overrides recorder.data_dir)\n"
    "The control token comes from $TRIBOD_CONTROL_TOKEN (or the variable named by\n"
    "server.control_token_env), else server.control_token. Binding an address\n"
    "outside 127.0.0.0/8 needs a token. Exit codes: 0 stopped by a signal,\n"
    "1 cannot listen, 2 bad usage, config or bind policy.\n"
    "On start it prints 'tribod listening on ADDRESS:PORT' on stdout.\n";

struct Options {
  std::string config_path = "config/tribod.textproto";
  std::optional<unsigned long> port;
  std::optional<std::string> bind;
  std::optional<std::string> data_dir;
};

bool parse_args(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--config" && has_value) {
      o.config_path = argv[++i];
    } else if (arg == "--port" && has_value) {
      char* end = nullptr;
      o.port = std::strtoul(argv[++i], &end, 10);
      if (*end != '\0' || *o.port > 65535) return false;
    } else if (arg == "--bind" && has_value) {
      o.bind = argv[++i];
    } else if (arg == "--data-dir" && has_value) {
      o.data_dir = argv[++i];
    } else {
      return false;
    }
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  // Logs go to stderr; stdout carries only the "listening" line.
  spdlog::set_default_logger(spdlog::stderr_color_mt("tribod"));
  std::signal(SIGPIPE, SIG_IGN);  // a vanished reader must not kill the daemon
  spdlog::set_pattern("[%Y-%m-%dT%H:%M:%S.%e] [%n] [%l] %v");
  Options options;
  if (!parse_args(argc, argv, options)) {
    std::cerr << kUsage;
    return 2;
  }
  tribo::v1::DaemonConfig config;
  if (auto error = tribo::daemon::load_daemon_config(options.config_path, config)) {
    std::cerr << "tribod: " << *error << "\n";
    return 2;
  }
  if (options.port) config.mutable_server()->set_port(static_cast<std::uint32_t>(*options.port));
  if (options.bind) config.mutable_server()->set_bind_address(*options.bind);
  if (options.data_dir) config.mutable_recorder()->set_data_dir(*options.data_dir);

  // A data directory that cannot take a run is found now, not at the first
  // run's start (or, worse, its first block).
  {
    std::error_code ec;
    const std::filesystem::path dir = config.recorder().data_dir();
    std::filesystem::create_directories(dir, ec);
    std::string probe = (dir / ".tribod-write-test-XXXXXX").string();
    const int fd = ec ? -1 : ::mkstemp(probe.data());
    if (fd < 0) {
      std::cerr << "tribod: recorder.data_dir = \"" << dir.string() << "\" is not writable: "
                << (ec ? ec.message() : std::strerror(errno)) << "\n";
      return 2;
    }
    ::close(fd);
    ::unlink(probe.c_str());
  }

  const std::string token = tribo::daemon::resolve_control_token(config.server());
  if (auto refusal = tribo::daemon::check_bind_policy(config.server(), token)) {
    std::cerr << "tribod: " << *refusal << "\n";
    return 2;
  }

  asio::io_context io;
  std::unique_ptr<tribo::daemon::ApiServer> server;
  try {
    server = std::make_unique<tribo::daemon::ApiServer>(io, config.server(), token);
  } catch (const std::exception& e) {
    std::cerr << "tribod: cannot listen on " << config.server().bind_address() << ":"
              << config.server().port() << ": " << e.what() << "\n";
    return 1;
  }
  tribo::daemon::InstrumentService service(config, tribo::kSoftwareVersion, *server);
  server->attach(service);
  server->start_accepting();

  asio::signal_set signals(io, SIGINT, SIGTERM);
  std::thread stopper;
  signals.async_wait([&](std::error_code ec, int signal) {
    if (ec) return;
    spdlog::info("signal {}: unloading and stopping", signal);
    // The run thread posts its last documents onto io; shut down off the io
    // thread so that they can still be delivered, then close the sessions.
    stopper = std::thread([&] {
      service.shutdown("daemon received a termination signal");
      server->close_gracefully(std::chrono::seconds(2));
    });
  });

  std::printf("tribod listening on %s:%u\n", config.server().bind_address().c_str(),
              static_cast<unsigned>(server->port()));
  std::fflush(stdout);
  spdlog::info("tribo {} serving on {}:{} (backend: {}, loop {} Hz, data in {}, control {})",
               tribo::kSoftwareVersion, config.server().bind_address(), server->port(),
               service.backend_name(), config.controller().loop_rate_hz(), config.recorder().data_dir(),
               token.empty() ? "open to local clients" : "needs the token");
  io.run();
  if (stopper.joinable()) stopper.join();
  spdlog::info("stopped");
  return 0;
}
