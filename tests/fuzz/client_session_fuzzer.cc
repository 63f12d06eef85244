// libFuzzer target: a client session's request handling (daemon/client_session.h),
// not only the frame decoder: whatever bytes a connection sends are decoded,
// checked (handshake, role, field bounds), dispatched to a real
// InstrumentService on the simulated instrument and answered. Input: the
// bytes one connection sends. The daemon config is the repository's, unpaced,
// with a short autotune and a data directory of its own: a scratch directory
// made once per process (under $TMPDIR), holding one finished run with the
// fixed id kSeedRunId that the corpus's GetRun / FetchSamples / ExportCsv
// requests name, so that runs start, record and stop, and the read paths
// read a real recording.
//
// Each execution ends as a new connection would find the instrument: a run
// still going is aborted (so a long protocol costs no more than a short
// one), the runs the input started are checked and removed, the gains are
// restored, a fault is re-armed and the seed run's protocol is loaded again
// (as after start-up), so that an input does what it does whatever ran
// before it and a finding reproduces from its artifact alone. Nothing else
// touches the filesystem.
//
// Checked: nothing crashes or leaks under ASan/UBSan; the instrument is not
// RUNNING once the service is idle; every run the input started was
// finalized (its stop document written).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include "daemon/api_server.h"
#include "daemon/client_session.h"
#include "daemon/instrument_service.h"
#include "proto/run_files.h"
#include "proto/text_format_file.h"

namespace fs = std::filesystem;

namespace {

// The run the seed corpus asks for (tests/fuzz/make_corpus.py).
constexpr const char* kSeedRunId = "20260101-000000-000";

void check(bool ok) {
  if (!ok) __builtin_trap();
}

fs::path make_scratch_dir() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/tribo-fuzz-session.XXXXXX";
  if (!mkdtemp(pattern.data())) std::abort();
  return pattern;
}

struct Daemon {
  asio::io_context io;
  tribo::v1::DaemonConfig config;
  fs::path data_dir;
  std::unique_ptr<tribo::daemon::ApiServer> server;
  std::unique_ptr<tribo::daemon::InstrumentService> service;
  std::string last_run_id;
  tribo::v1::Protocol seed_protocol;  // loaded at start-up and again after each execution

  Daemon() {
    google::protobuf::SetLogHandler(nullptr);
    spdlog::set_level(spdlog::level::off);
    if (tribo::wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/tribod.textproto", config)) std::abort();
    data_dir = make_scratch_dir();
    config.mutable_recorder()->set_data_dir(data_dir.string());
    config.mutable_server()->set_port(0);
    config.mutable_server()->set_control_token("fuzz-token");
    config.mutable_autotune()->set_max_duration_s(0.01);
    config.mutable_controller()->set_pace_to_wall_clock(false);
    server = std::make_unique<tribo::daemon::ApiServer>(io, config.server(), "fuzz-token");
    service = std::make_unique<tribo::daemon::InstrumentService>(config, "fuzz", *server);
    server->attach(*service);
    record_seed_run();
    last_run_id = service->status().run_id();
    std::atexit([] { std::error_code ec; fs::remove_all(instance().data_dir, ec); });
  }

  static Daemon& instance();

  // One real run of a short protocol, kept under the fixed id.
  void record_seed_run() {
    tribo::v1::Protocol protocol;
    if (tribo::wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/protocols/standard_scratch.textproto", protocol)) {
      std::abort();
    }
    // As the corpus's "short" protocol: 3 s, within the velocity limit.
    const double durations_s[] = {0.5, 0.5, 1.0, 0.5, 0.5};
    for (int i = 0; i < protocol.segments_size() && i < 5; ++i) protocol.mutable_segments(i)->set_duration_s(durations_s[i]);
    protocol.mutable_segments(2)->mutable_lateral()->set_end_um(2.5);
    protocol.mutable_segments(3)->mutable_lateral()->set_end_um(2.5);
    seed_protocol = protocol;
    tribo::v1::LoadProtocolReply loaded;
    tribo::v1::StartRunReply started;
    auto error = service->load_protocol(protocol, loaded);
    if (!error) error = service->start_run(1, started);
    if (error) {
      std::fprintf(stderr, "client_session fuzzer: the seed run failed: %s\n", error->message().c_str());
      std::abort();
    }
    service->wait_until_idle();
    std::string read_error;
    auto run = tribo::wire::read_run_directory(data_dir / started.run_id(), read_error);
    if (!run || !run->metadata.has_stop()) std::abort();
    auto& m = run->metadata;
    m.mutable_start()->set_run_id(kSeedRunId);
    m.mutable_stop()->set_run_id(kSeedRunId);
    m.mutable_run_descriptor()->set_run_id(kSeedRunId);
    for (auto& e : *m.mutable_segment_events()) e.set_run_id(kSeedRunId);
    for (auto& f : *m.mutable_faults()) f.set_run_id(kSeedRunId);
    if (!tribo::wire::write_run_directory(data_dir / kSeedRunId, m, run->samples, read_error)) std::abort();
    fs::remove_all(data_dir / started.run_id());
  }

  // The input's runs: each must have its stop document; then they go. Only
  // their metadata is read (not the seed run's, nor any samples file).
  void check_and_remove_new_runs() {
    const std::string run_id = service->status().run_id();
    if (run_id == last_run_id) return;  // no run started: no directory to look at
    last_run_id = run_id;
    for (const auto& dir : tribo::wire::recorded_run_directories(data_dir)) {
      if (dir.filename() == kSeedRunId) continue;
      std::string error;
      const auto metadata = tribo::wire::read_run_metadata(dir, error);
      if (metadata) check(metadata->has_stop());
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  }

  void restore_gains() {
    const auto& c = config.controller();
    const std::pair<tribo::v1::ControlLoop, const tribo::v1::PidGains*> loops[] = {
        {tribo::v1::LOOP_LATERAL_DISPLACEMENT, &c.lateral_displacement()},
        {tribo::v1::LOOP_LATERAL_FORCE, &c.lateral_force()},
        {tribo::v1::LOOP_NORMAL_FORCE, &c.normal_force()},
        {tribo::v1::LOOP_NORMAL_DISPLACEMENT, &c.normal_displacement()}};
    for (const auto& [loop, gains] : loops) {
      tribo::v1::SetGainsReply reply;
      (void)service->set_gains(loop, *gains, reply);
    }
  }
};

Daemon& Daemon::instance() {
  static Daemon* d = new Daemon;  // never destroyed: libFuzzer exits the process
  return *d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Daemon& d = Daemon::instance();
  tribo::daemon::SessionLimits limits;
  limits.max_frame_bytes = 1 << 20;
  limits.queue_bytes = 1 << 20;
  asio::ip::tcp::socket socket(d.io);  // never connected: replies fail to send and close the session
  auto session = std::make_shared<tribo::daemon::ClientSession>(std::move(socket), *d.server, *d.service, limits);
  session->process(std::string_view(reinterpret_cast<const char*>(data), size));
  // A run the input left going ends here, through the stop sequence.
  if (d.service->status().state() == tribo::v1::RUNNING) (void)d.service->abort_run("fuzz: end of input");
  d.service->wait_until_idle();
  d.io.restart();
  d.io.poll();
  session->close();
  d.io.restart();
  d.io.poll();
  check(d.service->status().state() != tribo::v1::RUNNING);
  d.check_and_remove_new_runs();
  d.restore_gains();
  if (d.service->status().state() == tribo::v1::FAULTED) {
    tribo::v1::RearmReply r;
    (void)d.service->rearm(r);
  }
  tribo::v1::LoadProtocolReply loaded;
  (void)d.service->load_protocol(d.seed_protocol, loaded);
  return 0;
}
