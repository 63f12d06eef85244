// Cost of the controller and the supervisor per tick (goal: at most 1 µs),
// with and without the friction compensation (argument 1: the identified
// model of tests/data/friction_reports/identification.json fed forward), the
// friction observer alone, the whole tick with the simulated plant for
// context, and the wake-up jitter of the wall-clock pacer at 10 kHz (a
// histogram, reported only).
#include <benchmark/benchmark.h>
#include <sys/prctl.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <variant>
#include <vector>

#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "daemon/friction_observer.h"
#include "daemon/friction_report.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "daemon/safety_supervisor.h"
#include "daemon/tick_timing.h"
#include "hal/backend_factory.h"
#include "hal/wall_clock_pacer.h"
#include "proto/text_format_file.h"

namespace tribo::daemon {
namespace {

v1::DaemonConfig config() {
  v1::DaemonConfig c;
  if (auto e = load_daemon_config(TRIBO_SOURCE_DIR "/config/tribod.textproto", c)) throw std::runtime_error(*e);
  return c;
}

v1::Protocol standard() {
  v1::Protocol p;
  if (auto e = wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/protocols/standard_scratch.textproto", p)) {
    throw std::runtime_error(*e);
  }
  return p;
}

// The identified model the compensated benchmarks feed forward.
IdentifiedFriction model_of(const char* path) {
  const auto text = wire::read_file(path);
  if (!text) throw std::runtime_error(std::string("the friction model report is missing: ") + path);
  return std::get<FrictionReport>(read_friction_report(*text)).model;
}

const IdentifiedFriction& identified_model() {
  static const IdentifiedFriction m = model_of(TRIBO_SOURCE_DIR "/tests/data/friction_reports/identification.json");
  return m;
}

// tribo-fit's rate-and-state model of a break-away record (ageing law,
// presliding, the tilt).
const IdentifiedFriction& rate_state_model() {
  static const IdentifiedFriction m = model_of(TRIBO_SOURCE_DIR "/tests/data/friction_reports/breakaway.json");
  return m;
}

// What one tick sees: the reading, the setpoints of the load function and
// what the supervisor is told. Recorded from a run of the standard scratch
// on the simulated instrument, mid-scratch (loaded, sliding).
struct Recorded {
  std::vector<hal::SensorFrame> frames;
  std::vector<TickSetpoints> setpoints;
};

const Recorded& recorded() {
  static const Recorded r = [] {
    const v1::DaemonConfig c = config();
    const ProtocolCheck check = validate_protocol(standard(), c);
    auto t = hal::make_transducer(c, 1);
    Controller controller(controller_params_from_config(c));
    SegmentRunner runner(check.load_function);
    Recorded out;
    for (std::uint64_t tick = 0; tick < 120000; ++tick) {
      hal::SensorFrame f;
      t->read(f);
      MeasuredStart m;
      m.lateral_position_m = f.lateral_position_m;
      const TickSetpoints sp = runner.at(tick, m);
      t->write(controller.step(sp, f).drive);
      t->wait_next_tick();
      if (tick >= 100000) {  // t = 10..12 s
        out.frames.push_back(f);
        out.setpoints.push_back(sp);
      }
    }
    return out;
  }();
  return r;
}

SupervisorInput supervisor_input(const hal::SensorFrame& f, const TickSetpoints& sp, const Controller& c) {
  SupervisorInput in;
  in.frame = f;
  in.drive = c.last_drive();
  in.lateral_setpoint_m = sp.lateral;
  in.lateral_setpoint_rate_m_per_s = sp.lateral_rate;
  return in;
}

// The recorded setpoints, with the compensation's model (argument 1) or not.
std::vector<TickSetpoints> setpoints_of(const benchmark::State& state) {
  std::vector<TickSetpoints> out = recorded().setpoints;
  for (TickSetpoints& sp : out) sp.friction_model = state.range(0) ? &identified_model() : nullptr;
  return out;
}

// Supervisor check plus controller step: the compute of a tick between the
// read and the write (with the compensation, its check before the write).
void BM_ControllerAndSupervisorTick(benchmark::State& state) {
  const v1::DaemonConfig c = config();
  const Recorded& r = recorded();
  const std::vector<TickSetpoints> setpoints = setpoints_of(state);
  auto controller = std::make_unique<Controller>(controller_params_from_config(c));
  auto supervisor = std::make_unique<SafetySupervisor>(supervisor_params_from_config(c));
  std::size_t i = 0;
  std::uint64_t tick = 0;
  bool tripped = false;
  for (auto _ : state) {
    const hal::SensorFrame& f = r.frames[i];
    const TickSetpoints& sp = setpoints[i];
    benchmark::DoNotOptimize(supervisor->check(supervisor_input(f, sp, *controller), tick));
    const ControlOutput out = controller->step(sp, f);
    if (out.friction_compensated) benchmark::DoNotOptimize(supervisor->compensation_allowed(out.friction_compensation_n, tick));
    benchmark::DoNotOptimize(out);
    ++tick;
    if (++i == r.frames.size()) {
      // The recording wraps (the position jumps back): a fresh controller
      // and supervisor, outside the timing.
      i = 0;
      state.PauseTiming();
      tripped = tripped || supervisor->tripped();
      controller = std::make_unique<Controller>(controller_params_from_config(c));
      supervisor = std::make_unique<SafetySupervisor>(supervisor_params_from_config(c));
      state.ResumeTiming();
    }
  }
  if (tripped || supervisor->tripped()) state.SkipWithError("the supervisor tripped on the recording");
}
BENCHMARK(BM_ControllerAndSupervisorTick)->Arg(0)->Arg(1);

void BM_SupervisorCheck(benchmark::State& state) {
  const v1::DaemonConfig c = config();
  const Recorded& r = recorded();
  Controller controller(controller_params_from_config(c));
  auto supervisor = std::make_unique<SafetySupervisor>(supervisor_params_from_config(c));
  std::size_t i = 0;
  std::uint64_t tick = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(supervisor->check(supervisor_input(r.frames[i], r.setpoints[i], controller), tick++));
    if (++i == r.frames.size()) {
      i = 0;
      state.PauseTiming();
      supervisor = std::make_unique<SafetySupervisor>(supervisor_params_from_config(c));
      state.ResumeTiming();
    }
  }
}
BENCHMARK(BM_SupervisorCheck);

void BM_ControllerStep(benchmark::State& state) {
  const v1::DaemonConfig c = config();
  const Recorded& r = recorded();
  const std::vector<TickSetpoints> setpoints = setpoints_of(state);
  Controller controller(controller_params_from_config(c));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(controller.step(setpoints[i], r.frames[i]));
    if (++i == r.frames.size()) i = 0;
  }
}
BENCHMARK(BM_ControllerStep)->Arg(0)->Arg(1);

// The friction observer's step alone, on the recorded readings. Argument 0:
// the shipped settings with identification.json; 1: breakaway.json, a
// rate-and-state model, with the shipped settings; 2: the same with its
// state at the measured speed (contact_state_from_measured_velocity,
// velocity_filter_hz 50).
void BM_FrictionObserverStep(benchmark::State& state) {
  const Recorded& r = recorded();
  const IdentifiedFriction& m = state.range(0) ? rate_state_model() : identified_model();
  ObserverSettings settings = controller_params_from_config(config()).friction_observer;
  if (state.range(0) == 2) {
    settings.contact_state_from_measured = true;
    settings.velocity_filter_hz = 50;
  }
  ObserverState s = observer_at_rest(m);
  std::size_t i = 0;
  for (auto _ : state) {
    ObserverInput in;
    in.position_m = r.frames[i].lateral_position_m;
    in.position_error_m = r.frames[i].lateral_position_m - r.setpoints[i].lateral;
    in.normal_force_n = r.frames[i].normal_force_n;
    in.commanded_velocity_m_per_s = r.setpoints[i].lateral_rate;
    in.period_s = 1e-4;
    benchmark::DoNotOptimize(observer_step(m, settings, in, s));
    if (++i == r.frames.size()) i = 0;
  }
}
BENCHMARK(BM_FrictionObserverStep)->Arg(0)->Arg(1)->Arg(2);

// The whole tick of the run loop with the simulated plant stepped in
// lock-step (read, supervise, control, write, record, plant step): the
// plant's RK4 sub-steps dominate.
void BM_RunLoopTickWithSimulatedPlant(benchmark::State& state) {
  const v1::DaemonConfig c = config();
  const ProtocolCheck check = validate_protocol(standard(), c);
  auto transducer = hal::make_transducer(c, 1);
  SpscQueue<Sample> queue(1 << 16);
  RunControl control;
  RunTelemetry telemetry;
  auto loop = std::make_unique<RunLoop>(*transducer, check.load_function, run_loop_config_from(c), queue, control, telemetry);
  Sample s;
  for (auto _ : state) {
    if (!loop->tick()) {
      state.PauseTiming();
      transducer = hal::make_transducer(c, 1);
      loop = std::make_unique<RunLoop>(*transducer, check.load_function, run_loop_config_from(c), queue, control, telemetry);
      state.ResumeTiming();
    }
    while (queue.try_pop(s)) {
    }
  }
}
BENCHMARK(BM_RunLoopTickWithSimulatedPlant);

// Paced at 10 kHz with clock_nanosleep(TIMER_ABSTIME): how late each wake-up
// is against its deadline, over 2 s (20000 ticks). Reported as counters and a
// histogram on stderr; never asserted. Argument 1: with the thread's timer
// slack at 1 ns, as the run loop sets it (Linux lets a sleep of an ordinary
// thread end up to 50 µs late by default).
void BM_PacedJitter(benchmark::State& state) {
  const unsigned long default_slack = static_cast<unsigned long>(prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0));
  prctl(PR_SET_TIMERSLACK, state.range(0) ? 1UL : default_slack, 0, 0, 0);
  constexpr double kPeriod = 1e-4;
  constexpr int kTicks = 20000;
  constexpr std::uint64_t kBinNs = 5000;
  for (auto _ : state) {
    hal::WallClockPacer pacer(kPeriod);
    const std::uint64_t start = monotonic_ns();
    std::vector<std::uint64_t> late_ns;
    late_ns.reserve(kTicks);
    std::uint64_t expected_tick = 0;
    for (int k = 0; k < kTicks; ++k) {
      const std::uint64_t overruns_before = pacer.overruns();
      pacer.wait();
      const std::uint64_t now = monotonic_ns();
      // The deadline just slept to: the next multiple of the period after the
      // previous one, skipping missed ones after an overrun.
      ++expected_tick;
      if (pacer.overruns() != overruns_before) {
        expected_tick = (now - start) / static_cast<std::uint64_t>(kPeriod * 1e9);
      }
      const std::uint64_t deadline = start + expected_tick * static_cast<std::uint64_t>(kPeriod * 1e9);
      late_ns.push_back(now > deadline ? now - deadline : 0);
    }
    std::vector<std::uint64_t> sorted = late_ns;
    std::sort(sorted.begin(), sorted.end());
    const auto pct = [&](double p) { return static_cast<double>(sorted[static_cast<std::size_t>(p * (kTicks - 1))]) * 1e-3; };
    state.counters["p50_us"] = pct(0.5);
    state.counters["p99_us"] = pct(0.99);
    state.counters["p999_us"] = pct(0.999);
    state.counters["max_us"] = static_cast<double>(sorted.back()) * 1e-3;
    state.counters["overruns"] = static_cast<double>(pacer.overruns());
    std::vector<int> bins(21, 0);
    for (const std::uint64_t l : late_ns) ++bins[std::min<std::uint64_t>(l / kBinNs, 20)];
    std::fprintf(stderr, "wake-up lateness at 10 kHz over %d ticks, timer slack %s (bins of 5 us):\n", kTicks,
                 state.range(0) ? "1 ns" : "default");
    for (std::size_t b = 0; b < bins.size(); ++b) {
      if (bins[b] == 0) continue;
      std::fprintf(stderr, "  %s%3zu us: %6d\n", b == 20 ? ">=" : "  ", b * 5, bins[b]);
    }
  }
  prctl(PR_SET_TIMERSLACK, default_slack, 0, 0, 0);
}
BENCHMARK(BM_PacedJitter)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tribo::daemon

BENCHMARK_MAIN();
