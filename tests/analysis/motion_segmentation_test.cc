#include <map>
#include <set>

#include <gtest/gtest.h>

#include "analysis/motion_segmentation.h"
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

}  // namespace
}  // namespace tribo::analysis
