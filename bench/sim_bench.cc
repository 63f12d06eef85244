// Simulated seconds per wall second of the full instrument: the simulated
// transducer and the controller in lock-step, no I/O, at the default 10 kHz.
#include <benchmark/benchmark.h>

#include <cmath>

#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "hal/backend_factory.h"
#include "hal/sim_transducer.h"
#include "proto/text_format_file.h"
#include "sim/instrument_params.h"

namespace {

tribo::v1::DaemonConfig default_config(const char* path = TRIBO_SOURCE_DIR "/config/tribod.textproto") {
  tribo::v1::DaemonConfig config;
  if (auto error = tribo::daemon::load_daemon_config(path, config)) {
    throw std::runtime_error(*error);
  }
  return config;
}

// One simulated second of the standard scratch's sliding part per iteration:
// 1 mN, 0.5 µm/s back and forth between +2 and +10 µm (one-sided, as the
// standard scratch), after a 1 s load ramp that is not timed.
// The config's own integrator.
void run_scratch(benchmark::State& state, const tribo::v1::DaemonConfig& config) {
  tribo::hal::SimTransducer transducer(tribo::sim::instrument_params_from_config(config.sim()), 1,
                                       config.controller().loop_rate_hz(), false);
  tribo::daemon::Controller controller(
      tribo::daemon::controller_params_from_config(config.controller()));
  const double dt = transducer.period_s();
  const long ticks_per_second = std::lround(1.0 / dt);
  long tick = 0;
  auto step = [&] {
    const double t = static_cast<double>(tick++) * dt;
    tribo::daemon::Setpoints sp;
    sp.normal_force_n = std::min(1.0, t) * 1e-3;
    const double phase = std::fmod(std::max(0.0, t - 1.0), 32.0);  // 16 s out, 16 s back
    sp.lateral_position_m = 2e-6 + 0.5e-6 * (phase < 16.0 ? phase : 32.0 - phase);
    tribo::hal::SensorFrame frame;
    transducer.read(frame);
    transducer.write(controller.step(sp, frame).drive);
    transducer.wait_next_tick();
  };
  for (long k = 0; k < ticks_per_second; ++k) step();
  for (auto _ : state) {
    for (long k = 0; k < ticks_per_second; ++k) step();
    benchmark::DoNotOptimize(transducer.instrument().truth());
  }
  state.counters["sim_s_per_wall_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// With the given integrator.
void run_scratch(benchmark::State& state, double max_h_lambda, tribo::v1::IntegrationMethod method,
                 tribo::v1::DaemonConfig config) {
  config.mutable_sim()->mutable_integrator()->set_max_h_lambda(max_h_lambda);
  config.mutable_sim()->mutable_integrator()->set_method(method);
  run_scratch(state, config);
}

// Accurate: RK4 with the law at every stage at h lambda <= 1 (lugre_plain's
// own integrator). Coarse: the midpoint rule at h lambda <= 1.2 (accuracy in
// tests/sim/integrator_accuracy_test.cc). Both on the plain LuGre plant
// (config/instruments/lugre_plain.textproto: LuGre with its Stribeck curve,
// no rate-and-state, presliding or dwell terms), beside dissertation_fit's below.
const char* const kPlainLugre = TRIBO_SOURCE_DIR "/config/instruments/lugre_plain.textproto";
void BM_InstrumentAccurate(benchmark::State& state) {
  run_scratch(state, 1.0, tribo::v1::INTEGRATION_RK4, default_config(kPlainLugre));
}
void BM_InstrumentCoarse(benchmark::State& state) {
  run_scratch(state, 1.2, tribo::v1::INTEGRATION_MIDPOINT, default_config(kPlainLugre));
}
const char* const kDissertationFit = TRIBO_SOURCE_DIR "/config/instruments/dissertation_fit.textproto";
// The contact fitted to the dissertation (the default's): rate-and-state,
// elasto-plastic presliding and dwell on top of LuGre, Table 5.1's loop
// gains; with its own integrator (the held contact law, h lambda <= 1.5), and
// with the law at every RK4 stage at h lambda <= 1.
void BM_InstrumentDissertationFit(benchmark::State& state) { run_scratch(state, default_config(kDissertationFit)); }
void BM_InstrumentDissertationFitLawAtEveryStage(benchmark::State& state) {
  run_scratch(state, 1.0, tribo::v1::INTEGRATION_RK4, default_config(kDissertationFit));
}

// The cost of the rate-and-state and elasto-plastic terms: the fitted contact
// with rate-and-state and elasto-plastic presliding switched off (dwell, the
// spot spread and the record noise kept), and plain LuGre with only the two
// switched on at their fitted values.
tribo::v1::DaemonConfig without_new_law(tribo::v1::DaemonConfig config) {
  tribo::v1::FrictionParams& friction = *config.mutable_sim()->mutable_friction();
  friction.mutable_rate_state()->set_enabled(false);
  friction.set_breakaway_ratio(0.0);
  return config;
}
tribo::v1::DaemonConfig with_new_law(tribo::v1::DaemonConfig config, const tribo::v1::DaemonConfig& fit) {
  tribo::v1::FrictionParams& friction = *config.mutable_sim()->mutable_friction();
  *friction.mutable_rate_state() = fit.sim().friction().rate_state();
  friction.set_breakaway_ratio(fit.sim().friction().breakaway_ratio());
  return config;
}
void BM_InstrumentDissertationFitWithoutNewLaw(benchmark::State& state) {
  run_scratch(state, 1.0, tribo::v1::INTEGRATION_RK4, without_new_law(default_config(kDissertationFit)));
}
void BM_InstrumentPlainWithNewLaw(benchmark::State& state) {
  run_scratch(state, 1.0, tribo::v1::INTEGRATION_RK4,
              with_new_law(default_config(kPlainLugre), default_config(kDissertationFit)));
}

// A whole protocol through the daemon's loop as tribo_native.simulate runs it
// (daemon/unpaced_run.cc), with the simulated plant's per-tick report: the C++ side of
// bench/sim_in_process_bench.py. Simulated seconds per CPU second over the
// protocol (config/protocols/identification.textproto, 198 s), and the
// evaluations of the contact law S per tick.
void run_protocol(benchmark::State& state, const char* config_path, const char* protocol_path) {
  const tribo::v1::DaemonConfig config = default_config(config_path);
  tribo::v1::Protocol protocol;
  if (auto error = tribo::wire::load_text_proto_file(protocol_path, protocol)) throw std::runtime_error(*error);
  const tribo::daemon::ProtocolCheck check = tribo::daemon::validate_protocol(protocol, config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  double simulated_s = 0;
  long ticks = 0, evaluations = 0, substeps = 0, split = 0;
  std::uint64_t seed = 0;
  for (auto _ : state) {
    auto transducer = tribo::hal::make_transducer(config, ++seed);
    const auto& sim = dynamic_cast<const tribo::hal::SimTransducer&>(*transducer);
    tribo::daemon::SpscQueue<tribo::Sample> queue(1 << 16);
    tribo::daemon::RunControl control;
    tribo::daemon::RunTelemetry telemetry;
    tribo::daemon::RunLoopConfig loop_config = tribo::daemon::run_loop_config_from(config);
    loop_config.backpressure = true;
    loop_config.time_stages_every = 0;
    tribo::daemon::RunLoop loop(*transducer, check.load_function, loop_config, queue, control, telemetry);
    tribo::Sample sample;
    while (loop.tick()) {
      while (queue.try_pop(sample)) simulated_s = sample.time_s;
      evaluations += sim.last_report().law_evaluations;
      substeps += sim.last_report().substeps;
      split += sim.last_report().split;
      ++ticks;
    }
    while (queue.try_pop(sample)) simulated_s = sample.time_s;
  }
  state.counters["sim_s_per_cpu_s"] =
      benchmark::Counter(simulated_s * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["S_evaluations_per_tick"] = static_cast<double>(evaluations) / static_cast<double>(ticks);
  state.counters["substeps_per_tick"] = static_cast<double>(substeps) / static_cast<double>(ticks);
  state.counters["split_ticks"] = static_cast<double>(split) / static_cast<double>(ticks);
}
const char* const kIdentification = TRIBO_SOURCE_DIR "/config/protocols/identification.textproto";
void BM_IdentificationDefault(benchmark::State& state) {
  run_protocol(state, TRIBO_SOURCE_DIR "/config/tribod.textproto", kIdentification);
}
void BM_IdentificationLugrePlain(benchmark::State& state) { run_protocol(state, kPlainLugre, kIdentification); }

}  // namespace

BENCHMARK(BM_IdentificationDefault)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_IdentificationLugrePlain)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_InstrumentAccurate)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InstrumentCoarse)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InstrumentDissertationFit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InstrumentDissertationFitLawAtEveryStage)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InstrumentDissertationFitWithoutNewLaw)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InstrumentPlainWithNewLaw)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
