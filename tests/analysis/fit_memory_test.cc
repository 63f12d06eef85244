// Heap the fit and the diagnosis take per sample ("peak memory
// under 300 bytes per sample"), counted, not sampled: this test binary
// interposes malloc and keeps the live and the peak bytes (glibc's usable
// size of every block), and the measured calls run on one thread, so the
// count is the same on every run. RSS is a benchmark figure
// (docs/testing.md), never asserted.
#include <malloc.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdio>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/models/model_fit.h"
#include "analysis/effects/regression.h"
#include "tests/analysis/synthetic_run.h"

extern "C" {
void* __libc_malloc(std::size_t);
void __libc_free(void*);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
}

namespace {

std::atomic<long long> g_live{0}, g_peak{0};

void note(long long delta) {
  const long long now = g_live += delta;
  long long peak = g_peak.load();
  while (now > peak && !g_peak.compare_exchange_weak(peak, now)) {
  }
}

long long usable(void* p) { return p ? static_cast<long long>(malloc_usable_size(p)) : 0; }

}  // namespace

extern "C" {
void* malloc(std::size_t n) noexcept {
  void* p = __libc_malloc(n);
  note(usable(p));
  return p;
}
void free(void* p) noexcept {
  note(-usable(p));
  __libc_free(p);
}
void* calloc(std::size_t count, std::size_t n) noexcept {
  void* p = __libc_calloc(count, n);
  note(usable(p));
  return p;
}
void* realloc(void* old, std::size_t n) noexcept {
  const long long before = usable(old);
  void* p = __libc_realloc(old, n);
  if (p || n == 0) note(usable(p) - before);
  return p;
}
void* memalign(std::size_t alignment, std::size_t n) noexcept {
  void* p = __libc_memalign(alignment, n);
  note(usable(p));
  return p;
}
void* aligned_alloc(std::size_t alignment, std::size_t n) noexcept { return memalign(alignment, n); }
int posix_memalign(void** out, std::size_t alignment, std::size_t n) noexcept {
  void* p = memalign(alignment, n);
  if (!p) return 12;  // ENOMEM
  *out = p;
  return 0;
}
}

namespace tribo::analysis {
namespace {

// Peak heap above the level at the start of fn, in bytes.
template <class Fn>
long long peak_heap_of(Fn fn) {
  const long long start = g_live.load();
  g_peak = start;
  fn();
  return g_peak.load() - start;
}

MeasuredSeries run_of(std::size_t samples) {
  testing::SyntheticOptions o;
  o.rate_hz = 1000;
  testing::SyntheticEffects e;
  e.tilt_tan = 0.026;
  MeasuredSeries s = testing::synthetic_run(e, 1, o);
  s = slice(s, 0, std::min(samples, s.size()));
  derive_motion(s, 0);
  return s;
}

TEST(FitMemory, TheFitNeedsOnlyTheJacobianAndAFewVectorsPerSample) {
  const MeasuredSeries s = run_of(40000);
  const MotionSegmentation m = segment_motion(s);
  const ModelData d(s, m);
  ModelStructure st;
  st.load_scaled = true;
  const ModelParams p = base_params(d, st);
  std::vector<char> in_fit(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) in_fit[i] = !m.heldout[i];
  FitResult fit;
  const long long peak = peak_heap_of([&] { fit = fit_model(d, p, in_fit, {8, 1e-6}); });
  const double per_sample = static_cast<double>(peak) / static_cast<double>(s.size());
  std::printf("fit_model, %zu samples, %zu free parameters: peak heap %.1f bytes per sample\n", s.size(), fit.k, per_sample);
  // The Jacobian (k = 7 doubles per fit sample) and two vectors of the
  // solver's: 44.1 measured (54.6 with two index arrays of the fit samples,
  // 222.6 before the Jacobian was streamed and factorised in place).
  EXPECT_LT(per_sample, 50);
  EXPECT_GT(fit.iterations, 0);
}

TEST(FitMemory, TheDiagnosisStaysUnder300BytesPerSampleOnOneThread) {
  const MeasuredSeries s = run_of(40000);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.threads = 1;
  Diagnosis d;
  const long long peak = peak_heap_of([&] { d = diagnose(s, options); });
  const double per_sample = static_cast<double>(peak) / static_cast<double>(s.size());
  std::printf("diagnose, %zu samples, one thread: peak heap %.1f bytes per sample (the input series not counted)\n",
              s.size(), per_sample);
  // 212.4 measured (203.9 before the minimum detectable strengths were
  // checked by rediagnosis, which holds a refit of the final model and a copy
  // of the force once the detectability basis is freed; 369 with the basis
  // still held; 227.9 with a copy of the score test's Jacobian in its
  // regression, the fit samples' indices in every fit and two unread
  // per-sample arrays of the segmentation; 629.3 before the Jacobian was
  // streamed: a dual number array per Jacobian, three more copies of it in
  // the solver, every candidate's model force kept).
  EXPECT_LT(per_sample, 300);
  EXPECT_LT(per_sample, 215);
  EXPECT_FALSE(d.trials.empty());
}

// The score test regresses the residual on the extension's Jacobian, the
// widest array of its phase: read in chunks, never copied (regress).
TEST(FitMemory, TheRegressionHoldsNoCopyOfItsDesignMatrix) {
  const Eigen::Index n = 100000, k = 10;
  Eigen::MatrixXd X(n, k);
  for (Eigen::Index j = 0; j < k; ++j) {
    for (Eigen::Index i = 0; i < n; ++i) X(i, j) = std::sin(0.001 * static_cast<double>((j + 1) * i)) + (i % (j + 3) == 0 ? 0.1 : 0.0);
  }
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) y[i] = 0.5 * X(i, 2) - 0.25 * X(i, 7) + 0.01 * std::cos(0.37 * static_cast<double>(i));
  Regression r;
  const long long peak = peak_heap_of([&] { r = regress(X, y); });
  const double x_bytes = static_cast<double>(n * k) * sizeof(double);
  std::printf("regress, %ld x %ld: peak heap %.2f of the design matrix\n", static_cast<long>(n), static_cast<long>(k),
              static_cast<double>(peak) / x_bytes);
  // The residual and a chunk of rows: 0.1 of X at k = 10; a copy of X is 1.
  EXPECT_LT(static_cast<double>(peak), 0.5 * x_bytes);
  ASSERT_TRUE(r.ok);
  // The least-squares coefficients of Eigen's QR of the whole matrix.
  const Eigen::VectorXd expected = X.colPivHouseholderQr().solve(y);
  for (Eigen::Index j = 0; j < k; ++j) EXPECT_NEAR(r.coef[j], expected[j], 1e-9) << j;
  EXPECT_NEAR(r.coef[2], 0.5, 1e-3);
  EXPECT_NEAR(r.coef[7], -0.25, 1e-3);
}

}  // namespace
}  // namespace tribo::analysis
