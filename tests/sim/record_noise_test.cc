// The record readout noise of the lateral position
// (sim.sensors.lateral_position_record_noise_m): the recorded position carries
// Table 3.2's 10 nm floor, the position loop and the tip do not see it, it is
// deterministic with the seed, and 0 records the loop's reading bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "scorecard/scorecard.h"
#include "tests/daemon/service_test_support.h"
#include "tests/sim/sim_test_support.h"

namespace tribo {
namespace {

using testing::LoopSetpoints;

v1::DaemonConfig with_record_noise(double rms_m) {
  v1::DaemonConfig config = testing::default_config();
  config.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(rms_m);
  return config;
}

// Per tick: the tip's true position, the loop's reading and the recorded position.
struct Trace {
  std::vector<double> truth, loop, recorded;
};

// Approach +2 um, load 1 mN over 1.5-2 s, rest until 4 s; ticks after 2.5 s.
Trace rest_at_1mN(const v1::DaemonConfig& config, std::uint64_t seed) {
  Trace tr;
  testing::run_closed_loop(
      config, seed, 4.0,
      [](double t) { return LoopSetpoints{std::clamp((t - 1.5) / 0.5, 0.0, 1.0) * 1e-3, 2e-6 * std::min(1.0, t / 0.3)}; },
      [&](double t, const hal::SimTransducer& h) {
        if (t < 2.5) return;
        const sim::Measurement& m = h.instrument().measurement();
        tr.truth.push_back(h.instrument().truth().lateral.position_m);
        tr.loop.push_back(m.lateral_position_m);
        tr.recorded.push_back(m.recorded_lateral_position_m());
      });
  return tr;
}

// RMS about the mean of each block of `block` samples: the noise above the
// slow wander and drift the stuck tip follows.
double block_rms(const std::vector<double>& v, std::size_t block) {
  double ss = 0;
  std::size_t n = 0;
  for (std::size_t b = 0; b + block <= v.size(); b += block) {
    double mean = 0;
    for (std::size_t k = b; k < b + block; ++k) mean += v[k];
    mean /= static_cast<double>(block);
    for (std::size_t k = b; k < b + block; ++k) ss += (v[k] - mean) * (v[k] - mean);
    n += block;
  }
  return std::sqrt(ss / static_cast<double>(n));
}

TEST(RecordNoise, RecordedPositionAtRestHasTheConfiguredRms) {
  const Trace tr = rest_at_1mN(with_record_noise(10e-9), 1);
  const double recorded = block_rms(tr.recorded, 1000), loop = block_rms(tr.loop, 1000);
  std::printf("  at rest, 0.1 s blocks: recorded %.3f nm RMS, loop reading %.3f nm RMS\n", recorded * 1e9, loop * 1e9);
  // 15000 samples: the RMS is estimated to 0.6 %; the loop's own reading adds
  // its 0.02 nm white floor and what the wander does within 0.1 s.
  EXPECT_NEAR(recorded, 10e-9, 0.3e-9);
  EXPECT_LT(loop, 1e-9) << "the loop's reading is not the record";
}

// The readout noise is outside the loop: the controller, hence the tip, and
// the loop's reading are bit-identical with and without it.
TEST(RecordNoise, NeitherTheLoopNorTheTipSeesIt) {
  const Trace noisy = rest_at_1mN(with_record_noise(10e-9), 3), clean = rest_at_1mN(with_record_noise(0), 3);
  ASSERT_EQ(noisy.truth.size(), clean.truth.size());
  EXPECT_EQ(noisy.truth, clean.truth);
  EXPECT_EQ(noisy.loop, clean.loop);
  EXPECT_NE(noisy.recorded, clean.recorded);
}

TEST(RecordNoise, IsDeterministicWithTheSeed) {
  const v1::DaemonConfig config = with_record_noise(10e-9);
  const Trace a = rest_at_1mN(config, 5), b = rest_at_1mN(config, 5), c = rest_at_1mN(config, 6);
  EXPECT_EQ(a.recorded, b.recorded);
  EXPECT_NE(a.recorded, c.recorded);
}

// Without it the record is the loop's reading, bit for bit (also the sign of a zero).
TEST(RecordNoise, ZeroRecordsTheLoopReadingBitForBit) {
  const Trace tr = rest_at_1mN(with_record_noise(0), 1);
  ASSERT_FALSE(tr.loop.empty());
  EXPECT_EQ(std::memcmp(tr.loop.data(), tr.recorded.data(), tr.loop.size() * sizeof(double)), 0);
  // The default records Table 3.2's 10 nm floor; plain LuGre
  // (config/instruments/lugre_plain.textproto) keeps the loop's reading, and its samples.
  EXPECT_EQ(testing::default_config().sim().sensors().lateral_position_record_noise_m(), 10e-9);
  EXPECT_EQ(testing::plain_lugre_config().sim().sensors().lateral_position_record_noise_m(), 0)
      << "lugre_plain keeps its samples";
}

// Through the daemon's real-time loop: the recorded samples carry the noise.
TEST(RecordNoise, TheRunLoopRecordsIt) {
  const v1::Protocol protocol = daemon::testing::parse_protocol(R"(
    acquisition_rate_hz: 10000
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { duration_s: 0.5 normal { end_uN: 1000 } lateral { shape: HOLD } }
    segments { duration_s: 1.5 normal { shape: HOLD } lateral { shape: HOLD } }
  )");
  auto recorded_rms = [&](double rms_m) {
    const auto run = daemon::testing::run_in_loop(with_record_noise(rms_m), protocol);
    EXPECT_EQ(run.outcome.end, daemon::RunEnd::kCompleted);
    std::vector<double> x;
    for (const Sample& s : run.samples) {
      if (s.time_s >= 2.0 && s.time_s < 3.0) x.push_back(s.lateral_position_m);
    }
    return block_rms(x, 1000);
  };
  const double noisy = recorded_rms(10e-9), clean = recorded_rms(0);
  std::printf("  recorded at rest: %.3f nm RMS with 10 nm of record noise, %.3f nm without\n", noisy * 1e9,
              clean * 1e9);
  EXPECT_NEAR(noisy, 10e-9, 0.4e-9);
  EXPECT_LT(clean, 1e-9);
}

// The scorecard's noise rows on the fitted configuration
// (docs/simulated_instrument.md): Table 3.2's floors in the record, each
// within 5 %, and the velocity noise of a 1 kHz record in sliding at
// 36 um/s: measured 2.47 um/s (the 10 nm per loop sample averaged to 3.2 nm
// per 1 ms sample gives 2.2 um/s by central differences).
TEST(RecordNoise, TheFittedConfigurationRecordsTable32Floors) {
  v1::DaemonConfig config;
  if (auto e = daemon::load_daemon_config(std::string(TRIBO_SOURCE_DIR) + "/config/instruments/dissertation_fit.textproto",
                                          config)) {
    FAIL() << *e;
  }
  scorecard::ScorecardOptions options;
  options.groups = {"noise"};
  const std::vector<scorecard::Row> rows = scorecard::run_scorecard(config, options);
  ASSERT_EQ(rows.size(), 5u);
  for (std::size_t i = 0; i < 4; ++i) {
    std::printf("  %s: %.4g %s (Table 3.2: %.4g)\n", rows[i].observation.c_str(), rows[i].simulated,
                rows[i].unit.c_str(), rows[i].dissertation);
    EXPECT_NEAR(rows[i].error(), 0, 0.05) << rows[i].observation;
  }
  std::printf("  %s: %.3g um/s\n", rows[4].observation.c_str(), rows[4].simulated);
  EXPECT_NEAR(rows[4].simulated, 2.47, 0.5);
}

}  // namespace
}  // namespace tribo
