#include <map>
#include <set>

#include <gtest/gtest.h>

#include "analysis/motion/motion_segmentation.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

TEST(MotionSegmentation, FindsThePassesAndHoldsOfTheSyntheticProtocol) {
  MeasuredSeries s = testing::synthetic_run({}, 3);
  derive_motion(s, 0);
  const MotionSegmentation m = segment_motion(s);
  // 3 loads x 4 speeds x 2 directions, each pass after a hold.
  ASSERT_EQ(m.passes.size(), 24u);
  EXPECT_GE(m.holds.size(), 24u);
  for (const Pass& p : m.passes) EXPECT_TRUE(p.after_hold);
  EXPECT_EQ(m.speed_levels_m_per_s.size(), 4u);
  EXPECT_EQ(m.load_levels_n.size(), 3u);
  // Dwell times of the protocol: 0.25 .. 8 s.
  double lo = 1e9, hi = 0;
  for (const Pass& p : m.passes) {
    lo = std::min(lo, p.dwell_before_s);
    hi = std::max(hi, p.dwell_before_s);
  }
  EXPECT_LT(lo, 0.5);
  EXPECT_GT(hi, 7.5);
}

TEST(MotionSegmentation, HoldsOutWholePassesUnderEveryCondition) {
  MeasuredSeries s = testing::synthetic_run({}, 3);
  derive_motion(s, 0);
  const MotionSegmentation m = segment_motion(s);
  EXPECT_FALSE(m.passes.front().heldout);
  EXPECT_FALSE(m.passes.back().heldout);
  // Every direction, speed and load level has fitted and held-out passes.
  std::map<std::string, std::set<bool>> seen;
  for (const Pass& p : m.passes) {
    seen["dir" + std::to_string(p.direction)].insert(p.heldout);
    seen["speed" + std::to_string(p.speed_level)].insert(p.heldout);
    seen["load" + std::to_string(p.load_level)].insert(p.heldout);
  }
  for (const auto& [condition, folds] : seen) EXPECT_EQ(folds.size(), 2u) << condition;
  // Samples of a pass share its fold: no random-sample split.
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (m.pass_of[i] < 0) continue;
    EXPECT_EQ(m.heldout[i] != 0, m.passes[static_cast<std::size_t>(m.pass_of[i])].heldout);
  }
}

TEST(MotionSegmentation, FallsBackToTimeChunksForASingleSweep) {
  MeasuredSeries s;
  for (int i = 0; i < 1000; ++i) {
    s.time_s.push_back(0.01 * i);
    s.position_m.push_back(1e-6 * i);
    s.force_n.push_back(1);
  }
  derive_motion(s, 0);
  const MotionSegmentation m = segment_motion(s);
  EXPECT_EQ(m.passes.size(), 1u);
  EXPECT_NE(m.heldout_scheme.find("time chunks"), std::string::npos);
  int held = 0;
  for (char h : m.heldout) held += h;
  EXPECT_EQ(held, 500);
}

// A tribo run: the setpoint holds still exactly, while the tip, behind a
// 0.2 s lag, is still creeping toward it all through the holds.
TEST(MotionSegmentation, TakesHoldsPassesAndDirectionsFromTheSetpoint) {
  auto setpoint_um = [](double t) {
    if (t < 0.5) return 0.0;                              // hold 0.5 s
    if (t < 0.6) return 10 * (t - 0.5);                   // + 1 um
    if (t < 0.85) return 1.0;                             // hold 0.25 s
    if (t < 0.95) return 1.0 - 10 * (t - 0.85);           // - 1 um, then turns at once
    if (t < 1.0) return 10 * (t - 0.95);                  // + 0.5 um with a 0.02 s stop
    if (t < 1.02) return 0.5;
    if (t < 1.07) return 0.5 + 10 * (t - 1.02);
    return 1.0;                                           // hold to the end
  };
  MeasuredSeries s;
  double x = 0;
  for (int i = 0; i < 320; ++i) {
    const double t = 0.005 * i;
    s.time_s.push_back(t);
    s.reference_m.push_back(1e-6 * setpoint_um(t));
    x += (s.reference_m.back() - x) * 0.005 / 0.2;
    s.position_m.push_back(x);
    s.force_n.push_back(1);
  }
  derive_motion(s, 0);
  SegmentationOptions options;
  options.segment_by_reference = true;
  const MotionSegmentation m = segment_motion(s, options);
  ASSERT_EQ(m.holds.size(), 3u);
  EXPECT_EQ(m.holds[1].first, 120u);  // t = 0.6 s: the setpoint stops, the tip does not
  ASSERT_EQ(m.passes.size(), 3u);
  EXPECT_EQ(m.passes[0].direction, +1);
  EXPECT_EQ(m.passes[1].direction, -1);
  EXPECT_EQ(m.passes[2].direction, +1);
  EXPECT_TRUE(m.passes[1].after_hold);
  EXPECT_NEAR(m.passes[1].dwell_before_s, 0.245, 1e-9);
  EXPECT_FALSE(m.passes[2].after_hold);  // a reversal
  EXPECT_EQ(m.passes[2].first, 190u);   // t = 0.95 s
  EXPECT_EQ(m.direction[202], +1);       // inside the 0.02 s stop
}

}  // namespace
}  // namespace tribo::analysis
