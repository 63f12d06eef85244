// Timings of the identification: the LuGre fit on 100 k samples
// (goal: at most 2 s) and a full diagnosis of a 200 s run at 1 kHz (goal: at
// most 30 s), on synthetic scratch series (tests/analysis/synthetic_run.h),
// plus the model simulation they are built on.
#include <benchmark/benchmark.h>

#include "analysis/diagnosis.h"
#include "analysis/models/lugre_fit.h"
#include "analysis/models/model_fit.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

MeasuredSeries run_of(std::size_t samples, const testing::SyntheticEffects& effects = {}) {
  testing::SyntheticOptions o;
  o.rate_hz = 1000;
  o.extra_loads = 1;  // 4 load sweeps, 227 s
  MeasuredSeries s = testing::synthetic_run(effects, 1, o);
  s = slice(s, 0, std::min(samples, s.size()));
  derive_motion(s, 0);
  return s;
}

std::vector<char> fit_mask(const MotionSegmentation& m) {
  std::vector<char> mask(m.heldout.size());
  for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = !m.heldout[i];
  return mask;
}

void BM_SimulateBase100k(benchmark::State& state) {
  const MeasuredSeries s = run_of(100000);
  const MotionSegmentation m = segment_motion(s);
  const ModelData d(s, m);
  ModelStructure st;
  st.load_scaled = true;
  const ModelParams p = base_params(d, st);
  for (auto _ : state) benchmark::DoNotOptimize(simulate(d, p));
}
BENCHMARK(BM_SimulateBase100k)->Unit(benchmark::kMillisecond);

void BM_JacobianBase100k(benchmark::State& state) {
  const MeasuredSeries s = run_of(100000);
  const MotionSegmentation m = segment_motion(s);
  const ModelData d(s, m);
  ModelStructure st;
  st.load_scaled = true;
  const ModelParams p = base_params(d, st);
  std::vector<int> columns;
  for (std::size_t k = 0; k < p.theta.size(); ++k) columns.push_back(static_cast<int>(k));
  std::vector<std::size_t> rows(s.size());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = i;
  for (auto _ : state) benchmark::DoNotOptimize(model_jacobian(d, p, p.theta, columns, rows));
}
BENCHMARK(BM_JacobianBase100k)->Unit(benchmark::kMillisecond);

// The whole LuGre fit: linear start, steady-state curve, 16 starts, two refined.
void BM_LugreFit100k(benchmark::State& state) {
  const MeasuredSeries s = run_of(100000);
  const MotionSegmentation m = segment_motion(s);
  const ModelData d(s, m);
  ModelStructure st;
  st.load_scaled = true;
  const auto mask = fit_mask(m);
  for (auto _ : state) {
    const LugreFit fit = fit_lugre(d, st, mask);
    state.counters["rms_uN"] = 1e6 * std::sqrt(fit.result.rss / static_cast<double>(fit.result.n));
    state.counters["jacobians"] = fit.result.iterations;
  }
  state.counters["samples"] = static_cast<double>(s.size());
}
BENCHMARK(BM_LugreFit100k)->Unit(benchmark::kMillisecond)->Iterations(3);

// Full diagnosis of a 200 s run at 1 kHz with one undeclared effect (tilt),
// on 1 and 2 threads (the argument): Google Benchmark's CPU column is the
// main thread's only, so compare the process's CPU time (perf stat).
void BM_Diagnosis200s(benchmark::State& state) {
  testing::SyntheticEffects e;
  e.tilt_tan = 0.026;
  const MeasuredSeries s = run_of(200000, e);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.threads = static_cast<unsigned>(state.range(0));
  for (auto _ : state) {
    const Diagnosis d = diagnose(s, options);
    state.counters["accepted"] = static_cast<double>(d.accepted.size());
    state.counters["trials"] = static_cast<double>(d.trials.size());
  }
  state.counters["samples"] = static_cast<double>(s.size());
}
BENCHMARK(BM_Diagnosis200s)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);

// What the minimum detectable strengths add (analysis/effects/detectability.h): the
// base fit alone (no candidate rounds) without (0) and with (1) the figure
// for every effect, on one thread so that the CPU time is the whole cost.
void BM_MinimumDetectable200s(benchmark::State& state) {
  const MeasuredSeries s = run_of(200000, testing::SyntheticEffects{});
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.max_rounds = 0;
  options.threads = 1;
  options.minimum_detectable = state.range(0) != 0;
  for (auto _ : state) {
    const Diagnosis d = diagnose(s, options);
    int figures = 0;
    for (const auto& r : d.rejected) figures += r.minimum_detectable.has_value();
    state.counters["figures"] = figures;
  }
}
BENCHMARK(BM_MinimumDetectable200s)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace tribo::analysis

BENCHMARK_MAIN();
