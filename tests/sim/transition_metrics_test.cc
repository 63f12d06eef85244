// The scorecard's definitions of a break-away transition on constructed
// records whose answers are known (scorecard/transition_metrics.h): Fs as the
// rise from the pre-motion reading and as the absolute peak; the velocity
// overshoot and the peak acceleration read through the dissertation's record
// (about 5000 points per experiment, velocities by successive differences).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "scorecard/transition_metrics.h"

namespace tribo::scorecard {
namespace {

constexpr double kDt = 1e-4;  // the 10 kHz loop

// A tip stuck until t0, then accelerating smoothly to K V at t0 + T/2 and
// settling back to V by t0 + T: v = K V sin^2(pi u / T) on the way up,
// V + (K - 1) V cos^2(pi (u - T/2) / T) on the way down (u = t - t0). Its
// largest acceleration is K V pi / T, at u = T / 4.
struct Bump {
  double v = 36e-6, k = 3.0, t0 = 0.1, t = 0.06;
  double velocity(double time) const {
    const double u = time - t0;
    if (u < 0) return 0;
    if (u < t / 2) return k * v * std::pow(std::sin(std::numbers::pi * u / t), 2);
    if (u < t) return v + (k - 1) * v * std::pow(std::cos(std::numbers::pi * (u - t / 2) / t), 2);
    return v;
  }
  double peak_acceleration() const { return k * v * std::numbers::pi / t; }
};

// Positions every tick from the onset (the tick's end), integrated finely.
std::vector<double> positions(const Bump& bump, double seconds, double noise_m, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> white(0.0, noise_m);
  std::vector<double> x;
  double position = 0;
  const int fine = 20;
  for (int k = 0; k < static_cast<int>(std::lround(seconds / kDt)); ++k) {
    for (int i = 0; i < fine; ++i) {
      position += bump.velocity((k + (i + 0.5) / fine) * kDt) * kDt / fine;
    }
    x.push_back(position + (noise_m > 0 ? white(rng) : 0.0));
  }
  return x;
}

TEST(DissertationRecord, HasAbout5000PointsOverTheLoadFunction) {
  // 16 s of load function plus a 16 µm scratch, 5000 points.
  EXPECT_NEAR(dissertation_record_interval_s(36.4e-6), 3.288e-3, 1e-6);
  EXPECT_NEAR(dissertation_record_interval_s(18e-6), 3.378e-3, 1e-6);
  EXPECT_NEAR(dissertation_record_interval_s(4e-6), 4.0e-3, 1e-9);
  EXPECT_NEAR(dissertation_record_interval_s(0.2e-6), 19.2e-3, 1e-9);
}

TEST(DissertationRecord, ReadsAKnownOvershootAndAcceleration) {
  const Bump bump;
  const std::vector<double> x = positions(bump, 0.4, 0, 1);
  const RecordedMotion m = motion_as_recorded(x, 0, kDt, dissertation_record_interval_s(bump.v));
  EXPECT_NEAR(m.peak_velocity_m_per_s / bump.v, bump.k, 0.03 * bump.k);
  EXPECT_NEAR(m.peak_acceleration_m_per_s2, bump.peak_acceleration(), 0.05 * bump.peak_acceleration());
  // The 4-point moving average of a smooth acceleration lowers its peak a little, no more.
  EXPECT_LT(m.peak_acceleration_ma4_m_per_s2, m.peak_acceleration_m_per_s2);
  EXPECT_GT(m.peak_acceleration_ma4_m_per_s2, 0.85 * bump.peak_acceleration());
}

// With Table 3.2's 10 nm of readout noise on every 10 kHz tick, the record
// (means of 33 ticks, 3.3 ms apart) still reads the tip's overshoot; single
// tick differences of the same readout would read the noise (141 µm/s RMS).
TEST(DissertationRecord, ReadsTheOvershootThroughTheReadoutNoise) {
  const Bump bump;
  const std::vector<double> x = positions(bump, 0.4, 10e-9, 7);
  const RecordedMotion m = motion_as_recorded(x, 0, kDt, dissertation_record_interval_s(bump.v));
  EXPECT_NEAR(m.peak_velocity_m_per_s / bump.v, bump.k, 0.1 * bump.k);
  EXPECT_NEAR(m.peak_acceleration_m_per_s2, bump.peak_acceleration(), 0.3 * bump.peak_acceleration());
  double tick_peak = 0;
  for (std::size_t k = 1; k < x.size(); ++k) tick_peak = std::max(tick_peak, (x[k] - x[k - 1]) / kDt);
  EXPECT_GT(tick_peak / bump.v, 3 * bump.k);
}

// A transition whose pre-motion reading is -200 µN (e.g. the tilt's push
// read before the onset): the force rises to 1300 µN at 0.1 s, holds 10 ms,
// and falls to a steady 1100 µN. Fs is 1500 µN as a rise, 1300 µN absolute.
TEST(MeasureTransition, FsAsTheRiseFromThePreMotionReadingAndAsTheAbsolutePeak) {
  TransitionRecord r;
  r.dt_s = kDt;
  r.velocity_m_per_s = 4e-6;
  r.force_before_n = -200e-6;
  r.position_before_m = 2e-6;
  for (int k = 0; k < 10000; ++k) {
    const double t = (k + 1) * kDt;
    double f = 1100e-6;
    if (t <= 0.1) {
      f = -200e-6 + 1500e-6 * t / 0.1;
    } else if (t <= 0.11) {
      f = 1300e-6;
    } else if (t <= 0.15) {
      f = 1300e-6 - 200e-6 * (t - 0.11) / 0.04;
    }
    r.force_n.push_back(f);
    r.setpoint_m.push_back(2e-6 + r.velocity_m_per_s * t);
    r.position_m.push_back(t <= 0.1 ? 2e-6 : 2e-6 + r.velocity_m_per_s * (t - 0.1));
  }
  const Breakaway b = measure_transition(r);
  EXPECT_TRUE(b.spike);
  EXPECT_NEAR(b.peak_n, 1300e-6, 1e-9);
  EXPECT_NEAR(b.rise_n, 1500e-6, 1e-9);
  // On the plateau (the 5 ms average reaches it 2.5 ms in).
  EXPECT_GE(b.time_to_peak_s, 0.1);
  EXPECT_LE(b.time_to_peak_s, 0.11);
  EXPECT_NEAR(b.stretch_m, 0, 0.02e-6);
  EXPECT_NEAR(b.lag_m, 0.4e-6, 1e-12);  // the 0.1 s the tip stood, times v
  EXPECT_NEAR(b.steady_n, 1100e-6, 1e-12);
}

}  // namespace
}  // namespace tribo::scorecard
