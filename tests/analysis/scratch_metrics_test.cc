#include <cmath>

#include <gtest/gtest.h>

#include "analysis/metrics/scratch_metrics.h"
#include "proto/sample_record.h"

namespace tribo::analysis {
namespace {

// Table 5.1 of the dissertation (§5.3): load, v0 (µm/s), ts (s), ds (µm), Fs (µN), mki, dl (µm), mk.
struct Row {
  double v0, ts, ds, fs, mki, dl, mk;
};
constexpr Row kTable51[] = {
    {0.2, 1.46, 0.13, 414, 1942, 0.054, 524},   {4, 0.23, 0.23, 487, 4603, 0.385, 443},
    {18, 0.114, 0.31, 617, 5275, 1.272, 373},   {36, 0.09, 0.30, 656, 4499, 2.21, 276},
    {0.2, 2.26, 0.27, 742, 1453, 0.27, 1961},   {4, 0.3, 0.35, 1273, 7074, 0.657, 1162},
    {18, 0.147, 0.41, 1394, 7167, 1.53, 609},   {36, 0.109, 0.46, 1520, 7108, 2.353, 465},
};

TEST(ScratchMetrics, Table51GainsFollowFromEquations26To33) {
  for (const Row& r : kTable51) {
    const Table51Gains g = table51_gains(r.fs * 1e-6, r.ts, r.ds * 1e-6, r.dl * 1e-6, r.v0 * 1e-6);
    // The table rounds its inputs; the gains agree to the table's own rounding.
    EXPECT_NEAR(g.integral_gain, r.mki, 0.01 * r.mki) << "v0 " << r.v0 << " Fs " << r.fs;
    EXPECT_NEAR(g.proportional_gain, r.mk, 0.015 * r.mk) << "v0 " << r.v0 << " Fs " << r.fs;
    EXPECT_NEAR(g.contact_stiffness_n_per_m, r.fs / r.ds, 1e-9 * r.fs / r.ds);
  }
}

v1::SampleBlock scratch_block() {
  v1::SampleBlock b;
  // seg 0: approach at zero load, x 0 -> 2 µm over a surface tilted by 0.01;
  // seg 1: loaded hold with a drift of 2 µN/s; seg 2: a scratch with a stiction peak.
  int k = 0;
  auto add = [&](std::uint32_t seg, double normal, double setpoint, double position, double force) {
    Sample s;
    s.time_s = 1e-3 * k++;
    s.segment_index = seg;
    s.normal_setpoint_n = normal;
    s.normal_force_n = normal;
    s.normal_displacement_m = 1e-9 + 0.01 * position;
    s.lateral_setpoint_m = setpoint;
    s.lateral_position_m = position;
    s.lateral_force_n = force;
    append_sample(s, b);
  };
  for (int i = 0; i < 1000; ++i) add(0, 0.0, 2e-9 * i, 2e-9 * i, 0.0);
  for (int i = 0; i < 2000; ++i) add(1, 1e-3, 2e-6, 2e-6, 5e-6 + 2e-6 * 1e-3 * i);
  for (int i = 0; i < 4000; ++i) {
    const double t = 1e-3 * i, x = 2e-6 + 1e-6 * t;  // 1 µm/s
    const double force = 100e-6 + 30e-6 * std::exp(-std::pow((t - 0.5) / 0.1, 2));  // peak at 0.5 s
    add(2, 1e-3, x, x - 0.05e-6, force);
  }
  return b;
}

TEST(ScratchMetrics, TiltDriftAndStretchFromARecordedScratch) {
  const v1::SampleBlock b = scratch_block();
  const auto tilt = fit_surface_tilt(b);
  ASSERT_TRUE(tilt);
  EXPECT_EQ(tilt->segment, 0u);
  EXPECT_NEAR(tilt->slope, 0.01, 1e-9);
  const auto depth = tilt_corrected_depth(b, *tilt);
  EXPECT_NEAR(depth[500], 0.0, 1e-15);

  const DriftFromHolds drift = lateral_drift_from_holds(b);
  ASSERT_EQ(drift.holds.size(), 1u);
  EXPECT_NEAR(drift.holds[0].rate_n_per_s, 2e-6, 1e-12);

  const auto ids = scratch_identification(b);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_NEAR(ids[0].metrics.stiction_peak_n, 130e-6, 0.5e-6);
  EXPECT_NEAR(ids[0].stretch_time_s, 0.5, 0.02);
  EXPECT_NEAR(ids[0].stretch_distance_m, 0.5e-6, 0.02e-6);
  EXPECT_NEAR(ids[0].metrics.steady_lag_m, 0.05e-6, 1e-12);
}

}  // namespace
}  // namespace tribo::analysis
