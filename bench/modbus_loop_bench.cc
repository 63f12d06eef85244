// The closed loop over loopback Modbus TCP: tribod's controller on the Modbus
// backend against tribo-bench's server (in a thread of this process, on the
// other core), one sensor read and one drive write per tick.
//
//   ClosedLoopUnpaced        as fast as the link allows: the sustainable loop rate
//   ClosedLoopPaced/RATE/P   paced by the wall clock for one second at RATE Hz:
//                            achieved rate and overruns, with the loop and the
//                            server thread placed by P:
//                              0 normal scheduling, any CPU
//                              1 SCHED_FIFO (loop 20, server 10), any CPU
//                              2 SCHED_FIFO, both on controller.loop_cpu (CPU 1
//                                in config/tribod-modbus.textproto): as shipped
// Counters: ticks_per_s, read/write/tick time p50, p99 and max in µs.
// Without CAP_SYS_NICE placements 1 and 2 run at normal priority (the
// counter realtime says which).
#include <benchmark/benchmark.h>
#include <sys/prctl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>
#include <vector>

#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "daemon/loop_scheduling.h"
#include "emulator/bench_server.h"
#include "hal/backend_factory.h"

namespace {

using namespace tribo;

v1::DaemonConfig load(const std::string& name) {
  v1::DaemonConfig c;
  if (auto e = daemon::load_daemon_config(std::string(TRIBO_SOURCE_DIR) + "/config/" + name, c)) {
    throw std::runtime_error(*e);
  }
  return c;
}

// tribo-bench's server on an ephemeral port, serving from its own thread.
// How the loop and the server threads are scheduled (ClosedLoopPaced's P).
enum class Placement { kNormal = 0, kRealtime = 1, kRealtimeSameCpu = 2 };

// Scheduling of the calling thread for this placement; true if real time.
bool place_thread(Placement placement, int priority, int cpu) {
  if (placement == Placement::kNormal) return false;
  return daemon::apply_loop_scheduling(priority, true,
                                       placement == Placement::kRealtimeSameCpu ? std::optional<int>(cpu)
                                                                                : std::nullopt)
      .realtime;
}

class ServerThread {
 public:
  explicit ServerThread(const v1::DaemonConfig& modbus, Placement placement = Placement::kNormal) {
    bench::BenchSetup setup;
    setup.bench.set_bind_address("127.0.0.1");
    setup.bench.set_port(0);
    setup.modbus = modbus;
    setup.physics = load("tribod.textproto");
    server_ = std::make_unique<bench::BenchServer>(setup);
    const int cpu = modbus.controller().has_loop_cpu() ? modbus.controller().loop_cpu() : 0;
    thread_ = std::thread([this, placement, cpu] {
      place_thread(placement, 10, cpu);
      server_->run(stop_);
    });
  }
  ~ServerThread() {
    stop_.store(true);
    thread_.join();
  }
  std::uint16_t port() const { return server_->port(); }

 private:
  std::unique_ptr<bench::BenchServer> server_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct Percentiles {
  explicit Percentiles(std::size_t n) { samples.reserve(n); }
  void add(double s) { samples.push_back(s); }
  void report(benchmark::State& state, const std::string& name) {
    if (samples.empty()) return;
    std::sort(samples.begin(), samples.end());
    const auto at = [&](double q) { return samples[static_cast<std::size_t>(q * static_cast<double>(samples.size() - 1))]; };
    state.counters[name + "_p50_us"] = at(0.50) * 1e6;
    state.counters[name + "_p99_us"] = at(0.99) * 1e6;
    state.counters[name + "_max_us"] = samples.back() * 1e6;
  }
  std::vector<double> samples;
};

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// One tick: read, control, write; times each part.
struct Loop {
  explicit Loop(const v1::DaemonConfig& config, std::uint16_t port)
      : config(config),
        transducer(hal::make_transducer(with_port(config, port), 1)),
        controller(daemon::controller_params_from_config(config.controller())) {}

  static v1::DaemonConfig with_port(v1::DaemonConfig c, std::uint16_t port) {
    c.mutable_modbus()->mutable_tcp()->set_port(port);
    c.mutable_modbus()->set_response_timeout_s(1.0);  // measure stalls, do not fault on them
    return c;
  }

  bool tick(std::uint64_t k, Percentiles& reads, Percentiles& writes, Percentiles& ticks) {
    daemon::Setpoints sp;
    sp.normal_force_n = 500e-6;
    sp.lateral_position_m = 2e-6 + 1e-6 * std::sin(static_cast<double>(k) * 1e-4);
    const auto t0 = std::chrono::steady_clock::now();
    hal::SensorFrame frame;
    const bool read_ok = transducer->read(frame) == hal::IoResult::kOk;
    const auto t1 = std::chrono::steady_clock::now();
    const bool write_ok = transducer->write(controller.step(sp, frame).drive) == hal::IoResult::kOk;
    const auto t2 = std::chrono::steady_clock::now();
    reads.add(std::chrono::duration<double>(t1 - t0).count());
    writes.add(std::chrono::duration<double>(t2 - t1).count());
    ticks.add(std::chrono::duration<double>(t2 - t0).count());
    return read_ok && write_ok;
  }

  v1::DaemonConfig config;
  std::unique_ptr<hal::Transducer> transducer;
  daemon::Controller controller;
};

void ClosedLoopUnpaced(benchmark::State& state) {
  const v1::DaemonConfig config = load("tribod-modbus.textproto");
  ServerThread server(config);
  Loop loop(config, server.port());
  Percentiles reads(1 << 20), writes(1 << 20), ticks(1 << 20);
  std::uint64_t k = 0, failures = 0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    if (!loop.tick(k++, reads, writes, ticks)) ++failures;
  }
  const double elapsed = seconds_since(start);
  state.counters["ticks_per_s"] = static_cast<double>(k) / elapsed;
  state.counters["failed_ticks"] = static_cast<double>(failures);
  reads.report(state, "read");
  writes.report(state, "write");
  ticks.report(state, "tick");
}
BENCHMARK(ClosedLoopUnpaced)->MinTime(3.0)->Unit(benchmark::kMicrosecond);

void ClosedLoopPaced(benchmark::State& state) {
  const double rate_hz = static_cast<double>(state.range(0));
  const auto placement = static_cast<Placement>(state.range(1));
  v1::DaemonConfig config = load("tribod-modbus.textproto");
  config.mutable_controller()->set_loop_rate_hz(rate_hz);
  ServerThread server(config, placement);
  const auto n = static_cast<std::uint64_t>(rate_hz);  // one second of wall clock
  for (auto _ : state) {
    // On a thread of its own: the placement must not outlive the run.
    std::thread([&] {
      const bool realtime = place_thread(placement, 20, config.controller().loop_cpu());
      Loop loop(config, server.port());
      Percentiles reads(n), writes(n), ticks(n);
      std::uint64_t failures = 0;
      prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);  // as tribod's loop thread
      const auto start = std::chrono::steady_clock::now();
      for (std::uint64_t k = 0; k < n; ++k) {
        if (!loop.tick(k, reads, writes, ticks)) ++failures;
        loop.transducer->wait_next_tick();
      }
      const double elapsed = seconds_since(start);
      state.counters["ticks_per_s"] = static_cast<double>(n) / elapsed;
      state.counters["overrun_fraction"] = static_cast<double>(loop.transducer->overruns()) / static_cast<double>(n);
      state.counters["failed_ticks"] = static_cast<double>(failures);
      state.counters["realtime"] = realtime ? 1 : 0;
      reads.report(state, "read");
      writes.report(state, "write");
      ticks.report(state, "tick");
    }).join();
  }
}
BENCHMARK(ClosedLoopPaced)
    ->ArgsProduct({{1000, 2000, 5000, 10000}, {0, 1, 2}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
