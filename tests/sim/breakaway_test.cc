// The static-to-kinetic transition of the simulated instrument against the
// dissertation's measurements (Table 5.1, §5.3.1, Fig. 4.22, Fig. 3.12), on
// the DEFAULT configuration (config/tribod.textproto: the slip-rate contact,
// config/instruments/dissertation_fit.textproto) where the test is about the
// default instrument, and on config/instruments/fitted_contact.textproto (the
// contact curve-fitted to them) where it holds that contact's figures
// (docs/simulated_instrument.md), through the scorecard's experiments.
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "daemon/daemon_config.h"
#include "scorecard/experiments.h"
#include "scorecard/scorecard.h"
#include "sim/capacitive_sensor.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

using scorecard::Breakaway;
using scorecard::BreakawayProtocol;

v1::DaemonConfig instrument_config(const std::string& name) {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/config/instruments/" + name + ".textproto";
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  return config;
}

// The break-away figures are checked on the default configuration: the one tribod
// loads when told nothing else.
v1::DaemonConfig default_instrument() { return testing::default_config(); }

Breakaway breakaway(const v1::DaemonConfig& config, double load_n, double velocity, double rest_s = 2.0) {
  BreakawayProtocol p;
  p.load_n = load_n;
  p.velocity_m_per_s = velocity;
  p.rest_s = rest_s;
  const Breakaway b = scorecard::run_breakaway(config, p, 1);
  std::printf("  %5.0f µN %4.1f µm/s rest %6.1f s: Fs %7.1f µN (spike %d, rise %7.1f µN) ts %.3f s ds %.3f µm "
              "dl %.3f µm overshoot %.2f (tip %.2f), peak acceleration %.0f µm/s² (tip %.0f)\n",
              load_n * 1e6, velocity * 1e6, rest_s, b.peak_n * 1e6, b.spike, b.rise_n * 1e6, b.time_to_peak_s,
              b.stretch_m * 1e6, b.lag_m * 1e6, b.overshoot, b.tip_overshoot, b.peak_acceleration_m_per_s2 * 1e6,
              b.tip_peak_acceleration_m_per_s2 * 1e6);
  return b;
}

// Table 5.1 at 9810 uN: Fs 1273 / 1394 / 1520 uN at 4 / 18 / 36 um/s, and
// ds 0.35 / 0.41 / 0.46 um: both grow with velocity. Plain LuGre's peak does
// not (config/instruments/lugre_plain.textproto: no spike, the rise from rest
// is largest at the lowest velocity).
TEST(Breakaway, PeakAndStretchGrowWithVelocityAt9810uN) {
  const v1::DaemonConfig config = default_instrument();
  const Breakaway slow = breakaway(config, 9810e-6, 4e-6);
  const Breakaway mid = breakaway(config, 9810e-6, 18e-6);
  const Breakaway fast = breakaway(config, 9810e-6, 36e-6);
  EXPECT_TRUE(slow.spike && mid.spike && fast.spike);
  EXPECT_GT(mid.peak_n, slow.peak_n);
  EXPECT_GT(fast.peak_n, mid.peak_n);
  EXPECT_GT(fast.stretch_m, slow.stretch_m);
}

TEST(Breakaway, PlainLugreHasNoSpikeAt9810uN) {
  const v1::DaemonConfig config = instrument_config("lugre_plain");
  for (double v : {4e-6, 18e-6, 36e-6}) EXPECT_FALSE(breakaway(config, 9810e-6, v).spike);
}

// §5.3.1: the tip's velocity overshoots about 3x after break-away, read
// from the dissertation's record (scorecard/transition_metrics.h). Without
// the record's readout noise, so that the tip's overshoot is tested, not the
// noise's (2.74x here, 2.76x with it). The fitted contact's figure: the
// default's slip-rate contact gives 1.95x at 18 um/s (below 2x; its shortfall
// is documented in docs/simulated_instrument.md).
TEST(Breakaway, VelocityOvershootsAtLeastTwiceAt18umPerS) {
  v1::DaemonConfig config = instrument_config("fitted_contact");
  config.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(0);
  EXPECT_GE(breakaway(config, 9810e-6, 18e-6).overshoot, 2.0);
}

// Fig. 4.22: the spike grows with the rest before the motion (3000 uN).
TEST(Breakaway, LongerRestGivesALargerSpike) {
  const v1::DaemonConfig config = default_instrument();
  const double short_rest = breakaway(config, 3000e-6, 4e-6, 0.5).peak_n;
  const double long_rest = breakaway(config, 3000e-6, 4e-6, 100).peak_n;
  EXPECT_GT(long_rest, short_rest * 1.01);
}

// A force held by the stuck contact stays (Fig. 3.12's drift needs it): 7 mN
// of load, slide 3 um at 4 um/s, stop, hold the position 100 s; the
// tilt-corrected lateral force, averaged over a second, keeps 80 % of what it
// was in the first second of the hold. Plain LuGre drains it under the
// position wander (checked below).
double held_fraction(const v1::DaemonConfig& config) {
  const double tilt = std::tan(config.sim().tip().tilt_offset().angle_deg() * M_PI / 180) *
                      (config.sim().tip().tilt_offset().enabled() ? 1 : 0);
  const double go = 3.0, stop = go + 0.75, end = stop + 100.0;
  double first = 0, last = 0;
  long n_first = 0, n_last = 0;
  testing::run_closed_loop(
      config, 1, end,
      [&](double t) {
        return testing::LoopSetpoints{std::clamp((t - 1.5) / 0.5, 0.0, 1.0) * 7e-3,
                                      2e-6 * std::min(1.0, t / 0.3) + 4e-6 * std::clamp(t - go, 0.0, stop - go)};
      },
      [&](double t, const hal::SimTransducer& h) {
        const Measurement& m = h.instrument().measurement();
        const double f = m.lateral_force_n + m.normal_force_n * tilt;
        if (t > stop + 0.5 && t <= stop + 1.5) {
          first += f;
          ++n_first;
        } else if (t > end - 1.0) {
          last += f;
          ++n_last;
        }
      });
  first /= static_cast<double>(n_first);
  last /= static_cast<double>(n_last);
  std::printf("  held force %.1f uN -> %.1f uN after 100 s\n", first * 1e6, last * 1e6);
  return last / first;
}

// On the fitted contact. The default's slip-rate contact relaxes a held force
// as rate-and-state contacts do in a hold after sliding (the contact keeps
// creeping, the force falling by about a N per e-fold of hold time: Marone
// 1998): 237 -> 121 uN here, and 265 -> 146 uN on a similar hold with the law
// at every RK4 stage at h lambda 0.05 (2026-11-29), so the relaxation is the
// law's, not the integrator's.
TEST(Breakaway, HeldForceAt7mNDoesNotDrainOver100s) {
  EXPECT_GT(held_fraction(instrument_config("fitted_contact")), 0.8);
}

TEST(Breakaway, PlainLugreDrainsTheHeldForce) { EXPECT_LT(held_fraction(instrument_config("lugre_plain")), 0.8); }

// The default is the fitted instrument: its simulated instrument and its
// lateral loop gains are config/instruments/dissertation_fit.textproto's (the
// scorecard figures of docs/simulated_instrument.md hold for both).
TEST(DefaultConfig, IsTheDissertationFit) {
  const v1::DaemonConfig d = default_instrument(), fit = instrument_config("dissertation_fit");
  std::string difference;
  google::protobuf::util::MessageDifferencer differ;
  differ.ReportDifferencesToString(&difference);
  EXPECT_TRUE(differ.Compare(fit.sim(), d.sim())) << difference;
  difference.clear();
  EXPECT_TRUE(differ.Compare(fit.controller().lateral_displacement(), d.controller().lateral_displacement()))
      << difference;
  EXPECT_TRUE(d.sim().friction().rate_state().enabled());
  EXPECT_GT(d.sim().friction().breakaway_ratio(), 0);
}

// Same config and seed: bit-identical results.
TEST(Breakaway, IsBitIdenticalForTheSameSeed) {
  const v1::DaemonConfig config = default_instrument();
  BreakawayProtocol p;
  p.velocity_m_per_s = 36e-6;
  const Breakaway a = scorecard::run_breakaway(config, p, 7), b = scorecard::run_breakaway(config, p, 7);
  EXPECT_EQ(a.peak_n, b.peak_n);
  EXPECT_EQ(a.time_to_peak_s, b.time_to_peak_s);
  EXPECT_EQ(a.stretch_m, b.stretch_m);
  EXPECT_EQ(a.lag_m, b.lag_m);
  EXPECT_EQ(a.overshoot, b.overshoot);
  EXPECT_EQ(a.steady_n, b.steady_n);
}

// The scorecard figures a contact reaches (docs/simulated_instrument.md): the
// goals are Fs within 25 %, ts within 30 %, dl within 25 % for each of Table
// 5.1's eight conditions, Fs read as the rise from the pre-motion reading.
struct Table51Goals {
  int fs, ts, dl;
};

Table51Goals table51_goals_met(const v1::DaemonConfig& config) {
  scorecard::ScorecardOptions options;
  options.groups = {"table_5_1"};
  Table51Goals met{0, 0, 0};
  for (const scorecard::Row& r : scorecard::run_scorecard(config, options)) {
    const std::string& what = r.quantity;  // Fs: the rise from the pre-motion reading
    if (r.goal > 0) std::printf("  %-40s %9.4g vs %9.4g: %+.1f %%\n", r.observation.c_str(), r.simulated, r.dissertation, 100 * r.error());
    if (what == "Fs") met.fs += r.within_goal();
    if (what == "ts") met.ts += r.within_goal();
    if (what == "dl") met.dl += r.within_goal();
  }
  return met;
}

// The fitted contact: Fs 7 of 8 (9810 µN at 0.2 µm/s is +29 %), ts 8 of 8, dl
// 5 of 8 (the 0.2 um/s rows and 9810 uN at 4 um/s: an I-PD loop's steady lag
// is v (kp + k) / ki whatever the contact).
TEST(Scorecard, TheFittedContactMeetsTheTable51GoalsItReached) {
  const Table51Goals met = table51_goals_met(instrument_config("fitted_contact"));
  EXPECT_GE(met.fs, 7);
  EXPECT_EQ(met.ts, 8);
  EXPECT_GE(met.dl, 5);
}

// The default's slip-rate contact, seed 1: Fs 6 of 8 (at 0.2 um/s the peaks
// are +31 % at 5000 uN and +40 % at 9810 uN: with the direct effect on the
// slip rate the peak hardly falls towards slow loading), ts 8 of 8, dl 5 of 8
// (the loop's lag, as above).
TEST(Scorecard, TheDefaultContactMeetsTheTable51GoalsItReached) {
  const Table51Goals met = table51_goals_met(default_instrument());
  EXPECT_GE(met.fs, 6);
  EXPECT_EQ(met.ts, 8);
  EXPECT_GE(met.dl, 5);
}

// Fig. 4.22 at 3000 uN: +1.2 % and +3.0 % after 30 and 100 s of rest, within
// 2 points (the 1000 s row runs in the scorecard, not here). The fitted
// contact's dwell term was fitted to the figure; the default's slip-rate
// contact, whose state ages by b ln t with the b Table 5.1 asks for, gives
// +12 % and +15 % (docs/simulated_instrument.md).
TEST(Scorecard, TheFittedContactMeetsFig422At3000uN) {
  scorecard::ScorecardOptions options;
  options.groups = {"fig_4_22"};
  options.quick = true;
  for (const scorecard::Row& r : scorecard::run_scorecard(instrument_config("fitted_contact"), options)) {
    std::printf("  %-45s %+.2f %% vs %+.2f %%\n", r.observation.c_str(), r.simulated, r.dissertation);
    if (r.observation.find("3000 uN") != std::string::npos) {
      EXPECT_TRUE(r.within_goal()) << r.observation;
    }
  }
}

// The position sensor reads the whole +-15 um travel (Table 3.2) of the
// shipped configurations. With V0 = 5 V its ADC (+-10 V) saturated at
// +13.77 um (the +x plate is nearer, so that side's voltage grows faster):
// config/instruments/lugre_plain.textproto keeps that, as it was.
TEST(PositionSensor, ReadsTheWholeTravelOfTheShippedConfigurations) {
  for (const std::string& path : {std::string(TRIBO_SOURCE_DIR) + "/config/tribod.textproto",
                                 std::string(TRIBO_SOURCE_DIR) + "/config/instruments/appendix_c.textproto",
                                 std::string(TRIBO_SOURCE_DIR) + "/config/instruments/dissertation_fit.textproto",
                                 std::string(TRIBO_SOURCE_DIR) + "/config/instruments/fitted_contact.textproto"}) {
    v1::DaemonConfig config;
    ASSERT_FALSE(daemon::load_daemon_config(path, config).has_value()) << path;
    CapacitiveSensingParams sensing = instrument_params_from_config(config.sim()).lateral_sensing;
    sensing.white_noise_m = sensing.low_frequency_noise_m = sensing.drift_m_per_s = 0;
    CapacitivePositionSensor sensor(sensing, 1, 2);
    for (double x : {-15e-6, -10e-6, 0.0, 10e-6, 13.77e-6, 14.5e-6, 15e-6}) {
      EXPECT_NEAR(sensor.sample(x, 0, 1e-4).position_m, x, 1e-10) << path << " at " << x * 1e6 << " um";
    }
  }
}

}  // namespace
}  // namespace tribo::sim
