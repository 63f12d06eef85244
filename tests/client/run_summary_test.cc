// The run summary's tilt correction on the simulated instrument: the tip
// tilt measured at rest under load, and the friction without the tilt's share.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/tip_tilt.h"
#include "client/run_summary.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::client {
namespace {

using daemon::testing::ServiceFixture;

// Runs the protocol in-process and summarizes it as `tribo run` does.
v1::RunSummary summarize(const v1::DaemonConfig& config, const v1::Protocol& protocol) {
  ServiceFixture f;
  const std::string data_dir = f.config.recorder().data_dir();
  f.config = config;
  f.config.mutable_recorder()->set_data_dir(data_dir);
  f.start();
  f.run(protocol);
  EXPECT_EQ(f.sink.starts.size(), 1u);
  EXPECT_EQ(f.sink.stops.size(), 1u);
  EXPECT_FALSE(f.sink.gaps);
  RunResult run;
  run.start = f.sink.starts.at(0);
  run.stop = f.sink.stops.at(0);
  run.samples = f.sink.samples;
  return summarize_run(run);
}

v1::DaemonConfig untilted_config() {
  v1::DaemonConfig c = tribo::testing::default_config();
  c.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  return c;
}

double configured_tan_tilt(const v1::DaemonConfig& c) {
  return std::tan(c.sim().tip().tilt_offset().angle_deg() * M_PI / 180);
}

// The standard scratch, and a variant with a 5 s loaded hold between the
// load and the scratch, each with and without tilt, on the same seed.
v1::Protocol with_loaded_hold(v1::Protocol p) {
  v1::Segment hold = p.segments(1);
  hold.set_name("hold");
  hold.set_duration_s(5);
  p.mutable_segments()->Add();
  for (int i = p.segments_size() - 1; i > 2; --i) *p.mutable_segments(i) = p.segments(i - 1);
  *p.mutable_segments(2) = hold;
  return p;
}

struct StandardScratch : ::testing::Test {
  static void SetUpTestSuite() {
    const v1::Protocol protocol = daemon::testing::load_protocol_file("standard_scratch.textproto");
    tilted = new v1::RunSummary(summarize(tribo::testing::default_config(), protocol));
    untilted = new v1::RunSummary(summarize(untilted_config(), protocol));
    held_tilted = new v1::RunSummary(summarize(tribo::testing::default_config(), with_loaded_hold(protocol)));
    held_untilted = new v1::RunSummary(summarize(untilted_config(), with_loaded_hold(protocol)));
  }
  static void TearDownTestSuite() {
    for (auto* s : {tilted, untilted, held_tilted, held_untilted}) delete s;
  }
  static inline v1::RunSummary* tilted = nullptr;
  static inline v1::RunSummary* untilted = nullptr;
  static inline v1::RunSummary* held_tilted = nullptr;
  static inline v1::RunSummary* held_untilted = nullptr;
};

// The estimate's error does not depend on the tilt: on the same seed the
// tilted and the untilted run differ by exactly the configured tilt.
TEST_F(StandardScratch, TheTiltMeasuredAtRestUnderLoadDiffersByTheConfiguredTilt) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  ASSERT_TRUE(config.sim().tip().tilt_offset().enabled());
  ASSERT_TRUE(tilted->has_tilt_tan());
  ASSERT_TRUE(untilted->has_tilt_tan());
  EXPECT_EQ(tilted->tilt_segment(), 1u);  // "load": the lateral setpoint holds while the load comes on
  RecordProperty("tilt_tan", std::to_string(tilted->tilt_tan()));
  RecordProperty("untilted_tilt_tan", std::to_string(untilted->tilt_tan()));
  const double tan_tilt = configured_tan_tilt(config);
  EXPECT_NEAR(tilted->tilt_tan() - untilted->tilt_tan(), tan_tilt, 0.01 * tan_tilt);
}

TEST_F(StandardScratch, TiltCorrectedFrictionDoesNotDependOnTheTilt) {
  ASSERT_EQ(tilted->scratches_size(), 1);
  ASSERT_EQ(untilted->scratches_size(), 1);
  const v1::SlidingSummary& t = tilted->scratches(0);
  const v1::SlidingSummary& u = untilted->scratches(0);
  ASSERT_TRUE(t.has_mean_friction_tilt_corrected_un());
  ASSERT_TRUE(u.has_mean_friction_tilt_corrected_un());
  RecordProperty("tilted_raw_uN", std::to_string(t.mean_friction_un()));
  RecordProperty("tilted_corrected_uN", std::to_string(t.mean_friction_tilt_corrected_un()));
  RecordProperty("untilted_raw_uN", std::to_string(u.mean_friction_un()));
  RecordProperty("untilted_corrected_uN", std::to_string(u.mean_friction_tilt_corrected_un()));
  // Uncorrected, the tilt takes N tan(theta) = 26 µN (20 %) off the friction.
  EXPECT_LT(t.mean_friction_un(), 0.85 * u.mean_friction_un());
  EXPECT_NEAR(t.mean_friction_tilt_corrected_un(), u.mean_friction_tilt_corrected_un(),
              0.001 * u.mean_friction_un());
  EXPECT_NEAR(t.mu_tilt_corrected(), t.mean_friction_tilt_corrected_un() / t.normal_force_un(), 1e-12);
}

// The standard scratch has no settled loaded rest: its only one is the load
// ramp, during which the position loop drags the loading tip forward (see
// README), so the bristles carry a force the estimate takes for tilt. A
// 5 s loaded hold before the scratch gives the estimate time to average out
// the bristles' wander at rest.
TEST_F(StandardScratch, ALoadedHoldRecoversTheTiltAndTheFriction) {
  const double tan_tilt = configured_tan_tilt(tribo::testing::default_config());
  ASSERT_TRUE(held_tilted->has_tilt_tan());
  ASSERT_TRUE(held_untilted->has_tilt_tan());
  RecordProperty("held_tilt_tan", std::to_string(held_tilted->tilt_tan()));
  RecordProperty("held_untilted_tilt_tan", std::to_string(held_untilted->tilt_tan()));
  EXPECT_NEAR(held_tilted->tilt_tan(), tan_tilt, 0.05 * tan_tilt);
  EXPECT_NEAR(held_untilted->tilt_tan(), 0, 0.1 * tan_tilt);
  ASSERT_EQ(held_tilted->scratches_size(), 1);
  ASSERT_EQ(held_untilted->scratches_size(), 1);
  const double untilted_friction = held_untilted->scratches(0).mean_friction_un();
  RecordProperty("held_corrected_uN", std::to_string(held_tilted->scratches(0).mean_friction_tilt_corrected_un()));
  EXPECT_NEAR(held_tilted->scratches(0).mean_friction_tilt_corrected_un(), untilted_friction,
              0.01 * untilted_friction);
}

TEST_F(StandardScratch, TheTextSummaryPrintsBothFrictions) {
  const std::string text = summary_text(*tilted);
  EXPECT_NE(text.find("mean friction"), std::string::npos) << text;
  EXPECT_NE(text.find("friction (tilt-corrected)"), std::string::npos) << text;
  EXPECT_NE(text.find("tip tilt   tan(theta) = "), std::string::npos) << text;
}

// A scratch that loads while the tip already moves has no loaded rest: the
// tilt stays unmeasured and the summary says so.
TEST(TiltCorrection, IsLeftUnsetWithoutALoadedRest) {
  v1::SampleBlock b;
  for (int i = 0; i < 100; ++i) {
    Sample s;
    s.time_s = i * 1e-3;
    s.segment_index = i < 50 ? 0 : 1;
    s.normal_setpoint_n = i * 1e-5;
    s.normal_force_n = s.normal_setpoint_n;
    s.lateral_setpoint_m = 2e-6 + i * 1e-8;
    s.lateral_position_m = s.lateral_setpoint_m;
    s.lateral_force_n = 0.1 * s.normal_force_n - 0.026 * s.normal_force_n;
    append_sample(s, b);
  }
  EXPECT_FALSE(analysis::estimate_tip_tilt(b).has_value());
  RunResult run;
  run.samples = b;
  run.start.set_loop_rate_hz(10000);
  const v1::RunSummary summary = summarize_run(run);
  EXPECT_FALSE(summary.has_tilt_tan());
  ASSERT_GE(summary.scratches_size(), 1);
  EXPECT_FALSE(summary.scratches(0).has_mean_friction_tilt_corrected_un());
  EXPECT_NE(summary_text(summary).find("tip tilt   not measured"), std::string::npos) << summary_text(summary);
}

TEST(TiltCorrection, AddsTheTiltShareAlongTheMotion) {
  // reading = F sgn(v) - N tan(theta): +x reads F - N t, -x reads -(F + N t).
  const double f = 100e-6, n = 1e-3, t = 0.02;
  const double reading_forward = f - n * t, reading_backward = -(f + n * t);
  // mean_friction is the reading times sgn(v).
  EXPECT_NEAR(analysis::tilt_corrected_friction_n(+reading_forward, +1e-6, n, t), f, 1e-15);
  EXPECT_NEAR(analysis::tilt_corrected_friction_n(-reading_backward, -1e-6, n, t), f, 1e-15);
}

}  // namespace
}  // namespace tribo::client
