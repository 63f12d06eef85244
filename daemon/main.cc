// tribod: the tribo daemon. Loads its config, serves the socket API and runs
// protocols on the configured transducer backend.
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <asio.hpp>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/daemon_config.h"
#include "daemon/instrument_service.h"
#include "hal/backend_factory.h"
#include "tribo/version.h"

namespace {

constexpr const char* kFooter =
    "The control token comes from $TRIBOD_CONTROL_TOKEN (or the variable named by\n"
    "server.control_token_env), else server.control_token. Binding an address\n"
    "outside 127.0.0.0/8 needs a token. Exit codes: 0 stopped by a signal,\n"
    "1 cannot listen, 2 bad usage, config or bind policy.\n"
    "On start it prints 'tribod listening on ADDRESS:PORT' on stdout; logs go to\n"
    "stderr (and --log-file), times in UTC.\n";

struct Options {
  std::string config_path = "config/tribod.textproto";
  std::optional<std::uint16_t> port;
  std::optional<std::string> bind;
  std::optional<std::string> data_dir;
  std::string log_level = "info";
  std::optional<std::string> log_file;
};

// Logs to stderr (and a file), UTC times with their zone, at the given level.
std::optional<std::string> set_up_logging(const Options& o) {
  std::vector<spdlog::sink_ptr> sinks{std::make_shared<spdlog::sinks::stderr_color_sink_mt>()};
  if (o.log_file) {
    try {
      sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(*o.log_file));
    } catch (const spdlog::spdlog_ex& e) {
      return "--log-file " + *o.log_file + ": " + e.what();
    }
  }
  auto logger = std::make_shared<spdlog::logger>("tribod", sinks.begin(), sinks.end());
  logger->set_level(spdlog::level::from_str(o.log_level));
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%Y-%m-%dT%H:%M:%S.%eZ] [%n] [%l] %v", spdlog::pattern_time_type::utc);
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGPIPE, SIG_IGN);  // a vanished reader must not kill the daemon
  Options options;
  CLI::App app{"tribod: the tribo daemon; serves the socket API and runs protocols", "tribod"};
  app.set_version_flag("--version", std::string("tribod ") + tribo::kSoftwareVersion);
  app.footer(kFooter);
  app.add_option("--config", options.config_path, "daemon config, protobuf text format")->capture_default_str();
  app.add_option("--port", options.port, "TCP port to listen on; 0 picks a free one (overrides server.port)");
  app.add_option("--bind", options.bind, "address to listen on (overrides server.bind_address)");
  app.add_option("--data-dir", options.data_dir, "where runs are recorded (overrides recorder.data_dir)");
  app.add_option("--log-level", options.log_level, "trace, debug, info, warn, error, critical or off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
      ->capture_default_str();
  app.add_option("--log-file", options.log_file, "also write the log to this file (appended)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  // Logs go to stderr; stdout carries only the "listening" line.
  if (auto error = set_up_logging(options)) {
    std::cerr << "tribod: " << *error << "\n";
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
