// The emergency stop's latency under every activity of the supervised loop,
// on the simulated instrument paced to the wall clock at the
// shipped loop rate (10 kHz: one period is 100 µs). Reported, not asserted
// (timings are figures). Activities:
//   Run            a loaded dwell of a protocol run
//   StopSequence   an abort's stop sequence already unloading
//   Autotune       the relay experiment
//   RearmCheck     the re-arm check reading the instrument
//   Idle           nothing running: latched at once
// Each is measured two ways: /0/* calls the service directly, /1/* sends
// EmergencyStop through the daemon's socket API (in process, loopback); and
// with the loop at normal priority (*/0) or SCHED_FIFO 20 (*/20,
// controller.loop_realtime_priority; counter realtime = 1 when granted).
// Counters:
//   loop_us_mean, loop_us_max   the request's arrival in the service to the
//                               loop having written the safe drive (run, stop
//                               sequence, autotune) or ended the check
//   reply_us_mean, reply_us_max (/1) client send -> reply received
//   loop_period_us, load_avg_1min (getloadavg at the end: the machine's load)
//   build/bench/estop_latency_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <google/protobuf/text_format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <memory>
#include <thread>

#include <asio.hpp>

#include "client/tribo_client.h"
#include "daemon/api_server.h"
#include "daemon/instrument_service.h"
#include "proto/text_format_file.h"

namespace {

using namespace tribo;

v1::DaemonConfig paced_config(const std::filesystem::path& data_dir) {
  v1::DaemonConfig c;
  if (wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/tribod.textproto", c)) std::abort();
  c.mutable_controller()->set_pace_to_wall_clock(true);
  c.mutable_recorder()->set_data_dir(data_dir.string());
  c.mutable_server()->set_bind_address("127.0.0.1");
  c.mutable_server()->set_port(0);
  return c;
}

v1::Protocol dwell_protocol() {
  v1::Protocol p;
  google::protobuf::TextFormat::ParseFromString(R"(
    name: "dwell"
    acquisition_rate_hz: 1000
    segments { name: "approach" duration_s: 0.2 normal { end_uN: 0 } lateral { end_um: 3 } }
    segments { name: "load" duration_s: 0.2 normal { end_uN: 1000 } lateral { shape: HOLD } }
    segments { name: "dwell" duration_s: 600 normal { shape: HOLD } lateral { shape: HOLD } }
  )", &p);
  return p;
}

enum class Activity { kRun, kStopSequence, kAutotune, kRearmCheck, kIdle };

// The daemon in process: the service, its API server on an io thread, and
// (for /1) one observer client over loopback.
struct Daemon {
  explicit Daemon(const v1::DaemonConfig& config, bool socket)
      : server(io, config.server(), ""), service(config, "bench", server) {
    server.attach(service);
    server.start_accepting();
    io_thread = std::thread([this] { io.run(); });
    if (socket) client = std::make_unique<client::TriboClient>(client::Address{"127.0.0.1", server.port()},
                                                               client::SessionOptions{});
  }
  ~Daemon() {
    client.reset();
    service.shutdown("bench done");
    server.close_gracefully(std::chrono::milliseconds(100));
    guard.reset();
    io.stop();
    io_thread.join();
  }
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> guard = asio::make_work_guard(io);
  daemon::ApiServer server;
  daemon::InstrumentService service;
  std::thread io_thread;
  std::unique_ptr<client::TriboClient> client;
};

void wait_for_activity(daemon::InstrumentService& service, const char* activity) {
  while (service.status().activity() != activity) std::this_thread::yield();
}

void measure(benchmark::State& state, Activity activity) {
  const bool socket = state.range(0) == 1;
  const auto dir = std::filesystem::temp_directory_path() / "tribo-estop-bench";
  std::filesystem::remove_all(dir);
  v1::DaemonConfig config = paced_config(dir);
  config.mutable_controller()->set_loop_realtime_priority(static_cast<int>(state.range(1)));
  bool realtime = false;
  double loop_sum_us = 0, loop_max_us = 0, reply_sum_us = 0, reply_max_us = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto d = std::make_unique<Daemon>(config, socket);
    daemon::InstrumentService& service = d->service;
    realtime = service.status().loop_scheduling().rfind("SCHED_FIFO", 0) == 0;
    std::future<void> activity_done;
    if (activity == Activity::kRun || activity == Activity::kStopSequence) {
      v1::LoadProtocolReply loaded;
      v1::StartRunReply started;
      if (service.load_protocol(dwell_protocol(), loaded) || service.start_run(std::nullopt, started)) std::abort();
      std::this_thread::sleep_for(std::chrono::milliseconds(600));  // into the loaded dwell
      if (activity == Activity::kStopSequence) {
        (void)service.abort_run("bench");
        std::this_thread::sleep_for(std::chrono::milliseconds(20));  // unloading now
      }
    } else if (activity == Activity::kAutotune) {
      auto promise = std::make_shared<std::promise<void>>();
      activity_done = promise->get_future();
      service.autotune_async(v1::Autotune{}, [promise](std::optional<v1::Error>, const v1::AutotuneReply&) {
        promise->set_value();
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    } else if (activity == Activity::kRearmCheck) {
      v1::EmergencyStopReply latched;
      (void)service.emergency_stop("bench: latch", latched);
      auto promise = std::make_shared<std::promise<void>>();
      activity_done = promise->get_future();
      service.rearm_async([promise](std::optional<v1::Error>, const v1::RearmReply&) { promise->set_value(); });
      wait_for_activity(service, "re-arm check");  // posted; 64 ticks: 6.4 ms at 10 kHz
      // Into the check itself, not its start on the loop thread.
      std::this_thread::sleep_for(std::chrono::milliseconds(3));
    }
    state.ResumeTiming();
    const auto sent = std::chrono::steady_clock::now();
    if (socket) {
      v1::ClientMessage estop;
      estop.mutable_emergency_stop()->set_reason("bench");
      if (!d->client->request(estop).has_emergency_stop()) std::abort();
    } else {
      v1::EmergencyStopReply reply;
      (void)service.emergency_stop("bench", reply);
    }
    const double reply_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - sent).count();
    state.PauseTiming();
    if (activity_done.valid()) activity_done.wait();
    service.wait_until_idle();
    const double loop_us = service.last_emergency_stop_latency_s() * 1e6;
    loop_sum_us += loop_us;
    loop_max_us = std::max(loop_max_us, loop_us);
    reply_sum_us += reply_us;
    reply_max_us = std::max(reply_max_us, reply_us);
    ++n;
    d.reset();
    state.ResumeTiming();
  }
  const double count = n > 0 ? static_cast<double>(n) : 1;
  state.counters["loop_us_mean"] = loop_sum_us / count;
  state.counters["loop_us_max"] = loop_max_us;
  if (socket) {
    state.counters["reply_us_mean"] = reply_sum_us / count;
    state.counters["reply_us_max"] = reply_max_us;
  }
  state.counters["realtime"] = realtime ? 1 : 0;
  state.counters["loop_period_us"] = 1e6 / config.controller().loop_rate_hz();
  double load[1] = {0};
  if (getloadavg(load, 1) == 1) state.counters["load_avg_1min"] = load[0];
  std::filesystem::remove_all(dir);
}

void BM_EstopDuringRun(benchmark::State& s) { measure(s, Activity::kRun); }
void BM_EstopDuringStopSequence(benchmark::State& s) { measure(s, Activity::kStopSequence); }
void BM_EstopDuringAutotune(benchmark::State& s) { measure(s, Activity::kAutotune); }
void BM_EstopDuringRearmCheck(benchmark::State& s) { measure(s, Activity::kRearmCheck); }
void BM_EstopIdle(benchmark::State& s) { measure(s, Activity::kIdle); }

BENCHMARK(BM_EstopDuringRun)->ArgsProduct({{0, 1}, {0, 20}})->Iterations(10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopDuringStopSequence)->ArgsProduct({{0, 1}, {0, 20}})->Iterations(10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopDuringAutotune)->ArgsProduct({{0, 1}, {0, 20}})->Iterations(10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopDuringRearmCheck)->ArgsProduct({{0, 1}, {0, 20}})->Iterations(20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopIdle)->ArgsProduct({{0, 1}, {0, 20}})->Iterations(20)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
