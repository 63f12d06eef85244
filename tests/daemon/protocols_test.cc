// The protocols shipped under config/protocols/: each passes the dry run and
// unrolls into what its comments promise; the short ones run on the
// simulated instrument and show what they are for.
#include <gtest/gtest.h>

#include <cmath>

#include <filesystem>
#include <set>

#include "daemon/protocol_validator.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

using testing::load_protocol_file;
using testing::mean_between;
using testing::run_in_loop;

ProtocolCheck check_file(const std::string& name) {
  return validate_protocol(load_protocol_file(name), tribo::testing::default_config());
}

std::string all(const ProtocolCheck& c) {
  std::string s;
  for (const auto& e : c.errors) s += e.field + ": " + e.message + "\n";
  return s;
}

TEST(ShippedProtocols, AllPassTheDryRunWithoutWarnings) {
  const std::set<std::string> expected{
      "standard_scratch.textproto",  "standard_scratch_tilt_hold.textproto",
      "velocity_sweep.textproto",    "stop_start.textproto",
      "velocity_reversal.textproto", "oscillation_amplitudes.textproto", "repeated_scratch.textproto",
      "breakaway.textproto",         "zero_load.textproto",              "identification.textproto",
      "creep_holds.textproto",       "breakaway_velocities.textproto"};
  std::set<std::string> found;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(TRIBO_SOURCE_DIR) + "/config/protocols")) {
    found.insert(entry.path().filename().string());
  }
  EXPECT_EQ(found, expected);
  for (const std::string& name : expected) {
    const ProtocolCheck c = check_file(name);
    EXPECT_TRUE(c.ok()) << name << "\n" << all(c);
    EXPECT_TRUE(c.warnings.empty()) << name << ": " << c.warnings.front();
  }
}

TEST(ShippedProtocols, VelocitySweepCoversFortyScratchesAtFiveLoads) {
  const ProtocolCheck c = check_file("velocity_sweep.textproto");
  ASSERT_TRUE(c.ok()) << all(c);
  std::multiset<long> speeds_nm_s;  // of the scratches, from duration and distance
  std::set<long> loads_un;
  int scratches = 0;
  for (const SegmentPlan& s : c.load_function.segments()) {
    if (s.name.rfind("load", 0) == 0) loads_un.insert(std::lround(s.normal.end * 1e6));
    if (s.name.rfind("scratch", 0) != 0) continue;
    ++scratches;
    ASSERT_TRUE(s.lateral.end_relative);
    EXPECT_DOUBLE_EQ(std::fabs(s.lateral.end), 9e-6);
    speeds_nm_s.insert(std::lround(9e-6 / (static_cast<double>(s.tick_count) / 1e4) * 1e9));
  }
  EXPECT_EQ(scratches, 40);
  EXPECT_EQ(loads_un, (std::set<long>{1000, 3000, 5000, 7000, 9810}));
  for (const long v : {200, 500, 1000, 2000, 5000, 10000, 20000, 40000}) EXPECT_EQ(speeds_nm_s.count(v), 5u) << v;
}

TEST(ShippedProtocols, IdentificationExcitesEveryEffect) {
  const ProtocolCheck c = check_file("identification.textproto");
  ASSERT_TRUE(c.ok()) << all(c);
  std::set<long> loads_un, speeds_nm_s, dwells_ms;
  int passes[2] = {0, 0}, sines = 0;
  for (const SegmentPlan& s : c.load_function.segments()) {
    const double seconds = static_cast<double>(s.tick_count) / c.load_function.loop_rate_hz();
    if (s.name.rfind("load", 0) == 0) loads_un.insert(std::lround(s.normal.end * 1e6));
    if (s.name.rfind("hold", 0) == 0) dwells_ms.insert(std::lround(seconds * 1e3));
    if (s.name.rfind("reversals", 0) == 0) ++sines;
    if (s.name.rfind("pass", 0) != 0 || s.name.rfind("passes", 0) == 0) continue;
    ASSERT_TRUE(s.lateral.end_relative);
    ++passes[s.lateral.end > 0 ? 0 : 1];
    speeds_nm_s.insert(std::lround(std::fabs(s.lateral.end) / seconds * 1e9));
  }
  EXPECT_EQ(loads_un, (std::set<long>{1000, 3000, 5000}));
  EXPECT_EQ(speeds_nm_s, (std::set<long>{400, 2000, 8000, 40000}));  // two decades
  EXPECT_EQ(passes[0], 12);  // forward
  EXPECT_EQ(passes[1], 12);  // backward
  EXPECT_EQ(sines, 3);
  EXPECT_EQ(dwells_ms, (std::set<long>{250, 300, 500, 1000, 2000, 4000, 6000, 8000}));
  EXPECT_LT(static_cast<double>(c.load_function.total_ticks()) / c.load_function.loop_rate_hz(), 210.0);
}

TEST(ShippedProtocols, StopStartRestsGrowAndSlidesRepeat) {
  const ProtocolCheck c = check_file("stop_start.textproto");
  ASSERT_TRUE(c.ok()) << all(c);
  std::vector<double> dwells;
  for (const SegmentPlan& s : c.load_function.segments()) {
    if (s.name.rfind("dwell", 0) == 0) dwells.push_back(static_cast<double>(s.tick_count) / 1e4);
  }
  EXPECT_EQ(dwells, (std::vector<double>{0.5, 1, 3, 10, 30}));
}

// Forward and backward strokes under the same load: friction changes sign
// and keeps its magnitude (no wear or debris in the simulated pair). The
// tilted tip (1.5 deg by default) adds -N tan(theta) to both strokes, so the
// half-difference is the friction and the half-sum the tilt.
TEST(ShippedProtocols, VelocityReversalFlipsTheFriction) {
  // Without the default's spot-to-spot variation of the sample (one draw of
  // 1.3 % RMS per seed), so that the friction is the model's: mu 0.0996 at
  // 13.5 um/s (§4.4) and flat in velocity (§4.4.3; 0.0971 at 4 um/s).
  v1::DaemonConfig config = tribo::testing::default_config();
  config.mutable_sim()->mutable_sample()->mutable_heterogeneity()->set_enabled(false);
  ASSERT_TRUE(config.sim().tip().tilt_offset().enabled());
  const double tan_tilt = std::tan(config.sim().tip().tilt_offset().angle_deg() * M_PI / 180);
  const auto run = run_in_loop(config, load_protocol_file("velocity_reversal.textproto"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted) << trip_description(run.outcome.trip);
  // Strokes of 2 s from t = 5 s; the second half of each is steady sliding.
  const double forward = mean_between(run.samples, 10, 11, &Sample::lateral_force_n);
  const double backward = mean_between(run.samples, 12, 13, &Sample::lateral_force_n);
  const double load = mean_between(run.samples, 10, 13, &Sample::normal_force_n);
  EXPECT_GT(forward, 150e-6);
  EXPECT_LT(backward, -150e-6);
  const double friction = (forward - backward) / 2;
  EXPECT_NEAR(friction, 0.0996 * load, 0.03 * friction);
  EXPECT_NEAR((forward + backward) / 2, -load * tan_tilt, 0.02 * friction);
}

// Small amplitudes stay in presliding: the friction force follows the
// position with the contact stiffness, far below the sliding level; the
// largest amplitude slides.
TEST(ShippedProtocols, OscillationsGoFromPreslidingToSliding) {
  const auto run = run_in_loop(tribo::testing::default_config(),
                               load_protocol_file("oscillation_amplitudes.textproto"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted) << trip_description(run.outcome.trip);
  const auto peak_force = [&](std::uint32_t segment) {
    double peak = 0;
    for (const Sample& s : run.samples) {
      if (s.segment_index == segment) peak = std::max(peak, std::fabs(s.lateral_force_n));
    }
    return peak;
  };
  const double sliding = 0.0996 * 996.7e-6;  // Coulomb level at this load
  EXPECT_LT(peak_force(2), 0.8 * sliding) << "0.02 µm: presliding";
  EXPECT_GT(peak_force(8), sliding) << "2 µm: gross sliding";
}

// Closed-loop normal force at zero: the measured contact force averages to
// zero within its noise and the tip carries no friction.
TEST(ShippedProtocols, ZeroLoadHoldsTheContactForceAtZero) {
  const auto run = run_in_loop(tribo::testing::default_config(), load_protocol_file("zero_load.textproto"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted) << trip_description(run.outcome.trip);
  // 16000 samples of 100 nN / sqrt(10) noise: a standard error of 0.25 nN.
  EXPECT_NEAR(mean_between(run.samples, 5, 21, &Sample::normal_force_n), 0, 2e-9);
  EXPECT_NEAR(mean_between(run.samples, 13, 21, &Sample::lateral_force_n), 0, 1e-6);
}

}  // namespace
}  // namespace tribo::daemon
