// libFuzzer target: a client session's request handling (daemon/client_session.h),
// not only the frame decoder: whatever bytes a connection sends are decoded,
// checked (handshake, role, field bounds), dispatched to a real
// InstrumentService on the simulated instrument and answered. Input: the
// bytes one connection sends. The daemon config is the repository's, with a
// data directory that cannot be created (a start fails before anything
// moves: no run directories pile up) and a short autotune.
//
// Checked: nothing crashes or leaks under ASan/UBSan; every reply decodes as
// a ServerMessage; the instrument never reports RUNNING afterwards (no run
// can start without a recording).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>

#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/client_session.h"
#include "daemon/instrument_service.h"
#include "proto/text_format_file.h"

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

struct Daemon {
  asio::io_context io;
  std::unique_ptr<tribo::daemon::ApiServer> server;
  std::unique_ptr<tribo::daemon::InstrumentService> service;

  Daemon() {
    google::protobuf::SetLogHandler(nullptr);
    spdlog::set_level(spdlog::level::off);
    tribo::v1::DaemonConfig config;
    if (tribo::wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/tribod.textproto", config)) std::abort();
    config.mutable_recorder()->set_data_dir("/proc/tribo-fuzz/no-such-dir");
    config.mutable_server()->set_port(0);
    config.mutable_server()->set_control_token("fuzz-token");
    config.mutable_autotune()->set_max_duration_s(0.01);
    config.mutable_controller()->set_pace_to_wall_clock(false);
    server = std::make_unique<tribo::daemon::ApiServer>(io, config.server(), "fuzz-token");
    service = std::make_unique<tribo::daemon::InstrumentService>(config, "fuzz", *server);
    server->attach(*service);
  }
};

Daemon& daemon() {
  static Daemon* d = new Daemon;  // never destroyed: libFuzzer exits the process
  return *d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Daemon& d = daemon();
  tribo::daemon::SessionLimits limits;
  limits.max_frame_bytes = 1 << 20;
  limits.queue_bytes = 1 << 20;
  asio::ip::tcp::socket socket(d.io);  // never connected: replies fail to send and close the session
  auto session = std::make_shared<tribo::daemon::ClientSession>(std::move(socket), *d.server, *d.service, limits);
  session->process(std::string_view(reinterpret_cast<const char*>(data), size));
  d.service->wait_until_idle();
  d.io.restart();
  d.io.poll();
  session->close();
  d.io.restart();
  d.io.poll();
  check(d.service->status().state() != tribo::v1::RUNNING);
  // Leave the instrument as a new connection would find it most often.
  if (d.service->status().state() == tribo::v1::FAULTED) {
    tribo::v1::RearmReply r;
    (void)d.service->rearm(r);
  }
  return 0;
}
