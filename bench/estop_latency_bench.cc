// The emergency stop's latency under every activity of the supervised loop
// (issue 13): from EmergencyStop's arrival in the service to the loop tick
// that acted on it, on the simulated instrument paced to the wall clock at
// the shipped loop rate (10 kHz: one period is 100 µs). Reported, not
// asserted (timings are figures):
//   BM_EstopDuringRun         a loaded dwell of a protocol run
//   BM_EstopDuringStopSequence  an abort's stop sequence already unloading
//   BM_EstopDuringAutotune    the relay experiment
//   BM_EstopIdle              nothing running: latched at once
// Counters: latency_us_mean, latency_us_max over the iterations, and the
// loop period for comparison.
//   build/bench/estop_latency_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <google/protobuf/text_format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <future>
#include <thread>

#include "daemon/instrument_service.h"
#include "proto/text_format_file.h"

namespace {

using namespace tribo;

struct NullSink : daemon::RunEventSink {
  void on_run_start(const v1::RunStart&) override {}
  void on_samples(const v1::SampleBlock&) override {}
  void on_run_stop(const v1::RunStop&) override {}
};

v1::DaemonConfig paced_config(const std::filesystem::path& data_dir) {
  v1::DaemonConfig c;
  if (wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/tribod.textproto", c)) std::abort();
  c.mutable_controller()->set_pace_to_wall_clock(true);
  c.mutable_recorder()->set_data_dir(data_dir.string());
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

enum class Activity { kRun, kStopSequence, kAutotune, kIdle };

void measure(benchmark::State& state, Activity activity) {
  const auto dir = std::filesystem::temp_directory_path() / "tribo-estop-bench";
  std::filesystem::remove_all(dir);
  const v1::DaemonConfig config = paced_config(dir);
  NullSink sink;
  double sum_us = 0, max_us = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    state.PauseTiming();
    daemon::InstrumentService service(config, "bench", sink);
    std::future<void> autotune_done;
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
      autotune_done = promise->get_future();
      service.autotune_async(v1::Autotune{}, [promise](std::optional<v1::Error>, const v1::AutotuneReply&) {
        promise->set_value();
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
    state.ResumeTiming();
    v1::EmergencyStopReply reply;
    (void)service.emergency_stop("bench", reply);
    state.PauseTiming();
    if (autotune_done.valid()) autotune_done.wait();
    service.wait_until_idle();
    const double latency_us = service.last_emergency_stop_latency_s() * 1e6;
    sum_us += latency_us;
    max_us = std::max(max_us, latency_us);
    ++n;
    state.ResumeTiming();
  }
  state.counters["latency_us_mean"] = n > 0 ? sum_us / static_cast<double>(n) : 0;
  state.counters["latency_us_max"] = max_us;
  state.counters["loop_period_us"] = 1e6 / config.controller().loop_rate_hz();
  std::filesystem::remove_all(dir);
}

void BM_EstopDuringRun(benchmark::State& s) { measure(s, Activity::kRun); }
void BM_EstopDuringStopSequence(benchmark::State& s) { measure(s, Activity::kStopSequence); }
void BM_EstopDuringAutotune(benchmark::State& s) { measure(s, Activity::kAutotune); }
void BM_EstopIdle(benchmark::State& s) { measure(s, Activity::kIdle); }

BENCHMARK(BM_EstopDuringRun)->Iterations(20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopDuringStopSequence)->Iterations(20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopDuringAutotune)->Iterations(20)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EstopIdle)->Iterations(20)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
