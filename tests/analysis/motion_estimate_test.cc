// The motion estimate from a noisy position record (analysis/motion/motion_estimate.h):
// noise floor from the record, velocity by the RTS smoother.
#include "analysis/motion/motion_estimate.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/input/measured_series.h"
#include "analysis/motion/gram_in_sample_order.h"

namespace tribo::analysis {
namespace {

// Table 3.2's lateral floors: 10 nm RMS position noise, 4 nm resolution, 500 Hz;
// passes of 5 um at 2 um/s there and back with smooth onsets (a 20 ms ramp) and
// 0.5 s holds.
struct Record {
  std::vector<double> t, x_true, v_true, x;
};

Record noisy_record(unsigned seed) {
  Record r;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 10e-9);
  const double dt = 1.0 / 500, speed = 2e-6, ramp = 0.02;
  double x = 0, v = 0, t = 0;
  int direction = 1;
  for (int cycle = 0; cycle < 6; ++cycle) {
    const double move = 5e-6 / speed;
    for (double s = 0; s < 0.5 + move; s += dt, t += dt) {
      double target = 0;
      if (s >= 0.5) target = direction * speed * std::min(1.0, (s - 0.5) / ramp);
      if (s >= 0.5 + move - ramp) target = direction * speed * std::max(0.0, (0.5 + move - s) / ramp);
      v = target;
      x += v * dt;
      r.t.push_back(t);
      r.x_true.push_back(x);
      r.v_true.push_back(v);
      r.x.push_back(std::round((x + noise(rng)) / 4e-9) * 4e-9);
    }
    direction = -direction;
  }
  return r;
}

double plateau_velocity_rms_error(const Record& r, const std::vector<double>& v) {
  double sse = 0;
  int n = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (std::fabs(std::fabs(r.v_true[i]) - 2e-6) > 1e-12) continue;  // plateaus only
    sse += (v[i] - r.v_true[i]) * (v[i] - r.v_true[i]);
    ++n;
  }
  return std::sqrt(sse / n);
}

TEST(MotionEstimate, NoiseFloorFromTheRecord) {
  const Record r = noisy_record(3);
  const MotionEstimate m = estimate_motion(r.t, r.x);
  // 10 nm white plus 4 nm quantisation (4/sqrt(12) = 1.2 nm RMS): 10.07 nm.
  EXPECT_NEAR(m.position_noise_m, 10.07e-9, 1.0e-9);
  EXPECT_NEAR(m.position_resolution_m, 4e-9, 1e-12);
  EXPECT_EQ(m.estimator, "rts_constant_acceleration");
}

TEST(MotionEstimate, SmootherVelocityIsTenTimesBetterThanCentralDifferences) {
  const Record r = noisy_record(17);
  const MotionEstimate m = estimate_motion(r.t, r.x);
  MeasuredSeries s;
  s.time_s = r.t;
  s.position_m = r.x;
  s.force_n.assign(r.t.size(), 0.0);
  derive_motion(s, 0);  // central differences, the old default
  const double central = plateau_velocity_rms_error(r, s.velocity_m_per_s);
  const double smoothed = plateau_velocity_rms_error(r, m.velocity_m_per_s);
  // Central differences: 10 nm * 500 Hz / sqrt(2) = 3.5 um/s of noise on a 2 um/s pass.
  EXPECT_GT(central, 3.0e-6);
  EXPECT_LT(smoothed, 0.3e-6) << "central " << central;
}

TEST(MotionEstimate, SeriesRecordsTheEstimatorAndKeepsAUserVelocity) {
  const Record r = noisy_record(41);
  MeasuredSeries s;
  s.time_s = r.t;
  s.position_m = r.x;
  s.force_n.assign(r.t.size(), 0.0);
  s.velocity_m_per_s = r.v_true;
  s.velocity_measured = true;
  derive_motion_smoothed(s);
  EXPECT_EQ(s.velocity_m_per_s, r.v_true);
  EXPECT_NE(s.motion_estimator.find("measured velocity"), std::string::npos);
  EXPECT_NEAR(s.position_noise_m, 10.07e-9, 1.0e-9);
  MeasuredSeries derived;
  derived.time_s = r.t;
  derived.position_m = r.x;
  derived.force_n.assign(r.t.size(), 0.0);
  derive_motion_smoothed(derived);
  EXPECT_EQ(derived.motion_estimator, "rts_constant_acceleration");
  EXPECT_GT(derived.velocity_noise_m_per_s, 0.0);
}

// Speed steps of a drive, 3 <-> 10 um/s every 60 s, at the basalt
// velocity-step record's floors (10 Hz, 0.14 um of position noise).
Record speed_steps(unsigned seed) {
  Record r;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.14e-6);
  const double dt = 0.1;
  double x = 0;
  for (int i = 0; i * dt <= 300; ++i) {
    const double v = static_cast<int>(i * dt / 60) % 2 == 0 ? 3e-6 : 10e-6;
    if (i > 0) x += v * dt;
    r.t.push_back(i * dt);
    r.x_true.push_back(x);
    r.v_true.push_back(v);
    r.x.push_back(x + noise(rng));
  }
  return r;
}

double velocity_rms_error_near_steps(const Record& r, const std::vector<double>& v) {
  double sse = 0;
  int n = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double since = std::fmod(r.t[i] + 1e-9, 60.0);
    if (r.t[i] < 30 || (since > 3 && since < 57)) continue;
    sse += (v[i] - r.v_true[i]) * (v[i] - r.v_true[i]);
    ++n;
  }
  return std::sqrt(sse / n);
}

// A velocity step is a jump, not a burst of jerk: with velocity jumps the
// smoother lets the velocity jump where the likelihood-ratio test finds one
// (each step, on the sample the new speed begins), and the velocity is right
// within a few samples of it.
TEST(MotionEstimate, SpeedStepsAreFoundAsVelocityJumps) {
  for (unsigned seed : {3u, 17u, 41u}) {
    const Record r = speed_steps(seed);
    const MotionEstimate m = estimate_motion(r.t, r.x, true);
    EXPECT_EQ(m.estimator, "rts_constant_acceleration_with_velocity_jumps");
    std::vector<std::size_t> steps;  // at 60, 120, 180 and 240 s (and on the last sample, 300 s: nothing after it to see)
    for (std::size_t i = 1; i + 1 < r.t.size(); ++i) {
      if (r.v_true[i] != r.v_true[i - 1]) steps.push_back(i);
    }
    ASSERT_EQ(steps.size(), 4u);
    std::vector<std::size_t> found = m.velocity_jumps;
    std::erase(found, r.t.size() - 1);
    EXPECT_EQ(found, steps) << "seed " << seed;
    // 0.05-0.40 um/s within 3 s of the steps; 0.82-0.85 um/s when the
    // jerk alone follows them (the default estimator).
    EXPECT_LT(velocity_rms_error_near_steps(r, m.velocity_m_per_s), 0.5e-6) << "seed " << seed;
  }
}

// A surge of the drive's position record that the contact never slid: on
// basalt velstep4 the position ran 10 -> 14 -> 10 um/s twice after the step,
// and the friction did not move. Here the steps above, with a friction that
// follows the true speed (a direct effect of 0.010 per e-fold at 20 MPa, the
// noise of 4e-4 in mu), and 2 s at 14 um/s in the record only, at 90 s: the
// test finds the surge's two jumps, and given the force takes only the steps.
TEST(MotionEstimate, AJumpTheForceDoesNotFollowIsNotTaken) {
  for (unsigned seed : {3u, 17u, 41u}) {
    Record r = speed_steps(seed);
    std::mt19937 rng(seed + 1000);
    std::normal_distribution<double> mu_noise(0.0, 4e-4);
    std::vector<double> force;
    double surge_m = 0;
    for (std::size_t i = 0; i < r.t.size(); ++i) {
      force.push_back(20e6 * (0.6 + 0.010 * std::log(r.v_true[i] / 1e-6) + mu_noise(rng)));
      if (r.t[i] > 90.05 && r.t[i] < 92.05) surge_m += 4e-6 * 0.1;
      r.x[i] += surge_m;
    }
    std::vector<std::size_t> steps;
    for (std::size_t i = 1; i + 1 < r.t.size(); ++i) {
      if (r.v_true[i] != r.v_true[i - 1]) steps.push_back(i);
    }
    const auto without_step_ends = [&](std::vector<std::size_t> found) {
      std::erase(found, r.t.size() - 1);
      return found;
    };
    const auto by_position = without_step_ends(estimate_motion(r.t, r.x, true).velocity_jumps);
    EXPECT_GE(by_position.size(), steps.size() + 2) << "seed " << seed;
    const MotionEstimate m = estimate_motion(r.t, r.x, true, force);
    EXPECT_EQ(without_step_ends(m.velocity_jumps), steps) << "seed " << seed;
    EXPECT_GE(m.velocity_jumps_force_did_not_follow, 2) << "seed " << seed;
  }
}

// A smooth motion (a 0.2 Hz sine of 5 um at Table 3.2's floors) has no jump
// for the test to find: at its 1 % level over the record, none is.
TEST(MotionEstimate, ASmoothMotionHasNoVelocityJumps) {
  for (unsigned seed : {3u, 17u, 41u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 10e-9);
    std::vector<double> t, x;
    for (int i = 0; i < 10000; ++i) {
      t.push_back(i / 500.0);
      x.push_back(std::round((5e-6 * std::sin(2 * M_PI * 0.2 * t.back()) + noise(rng)) / 4e-9) * 4e-9);
    }
    EXPECT_TRUE(estimate_motion(t, x, true).velocity_jumps.empty()) << "seed " << seed;
  }
}

// A servo of finite stiffness: the tip follows the reference through a
// 30 Hz first-order loop and yields to the friction force by F / 20 000 N/m.
// The friction is a LuGre bristle (2000 N/m, 100 uN when sliding) that keeps
// its force in the holds and reverses over 100 nm at the next pass: 10 nm
// yields, as large as the position noise. Passes of 4 um at 0.5, 2 and 8 um/s
// both ways, 0.5 s holds, 500 Hz.
struct YieldingRecord {
  std::vector<double> t, reference, x_true, x, force;
};

constexpr double kServoDt = 1.0 / 500, kBristleN_per_m = 2000, kBristleG = 100e-6 / kBristleN_per_m;

// The record's protocol and readout, for a servo whose tip and bristle
// `step(reference, loop_step, z)` advances by one sample (returning the tip's
// position, z updated): passes of 4 um at 0.5, 2 and 8 um/s both ways after
// 0.5 s holds, the loop a 30 Hz first-order lag of the reference, position
// read with 10 nm noise at 4 nm resolution, force with 1 uN at 3 uN.
template <typename Step>
YieldingRecord servo_record(unsigned seed, Step step) {
  YieldingRecord r;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double dt = kServoDt, pole = 1 - std::exp(-2 * M_PI * 30 * dt);
  double reference = 0, loop = 0, z = 0, t = 0;
  auto sample = [&](double velocity) {
    reference += velocity * dt;
    const double loop_step = (reference - loop) * pole;
    loop += loop_step;
    const double x = step(loop, loop_step, z);
    r.t.push_back(t);
    t += dt;
    r.reference.push_back(reference);
    r.x_true.push_back(x);
    r.x.push_back(std::round((x + 10e-9 * noise(rng)) / 4e-9) * 4e-9);
    r.force.push_back(std::round((kBristleN_per_m * z + 1e-6 * noise(rng)) / 3e-6) * 3e-6);
  };
  for (double speed : {0.5e-6, 2e-6, 8e-6, 2e-6, 0.5e-6, 8e-6}) {
    for (int direction : {1, -1}) {
      for (double s = 0; s < 0.5; s += dt) sample(0);
      for (double s = 0; s < 4e-6 / speed; s += dt) sample(direction * speed);
    }
  }
  return r;
}

// A servo of 20 000 N/m: the bristle stepped explicitly from the tip's
// velocity over the sample.
YieldingRecord yielding_record(unsigned seed) {
  const double k_servo = 20000;
  double x = 0;
  return servo_record(seed, [&](double loop, double, double& z) {
    const double x_next = loop - kBristleN_per_m * z / k_servo;
    const double v = (x_next - x) / kServoDt;
    z += (v - std::fabs(v) * z / kBristleG) * kServoDt;
    x = x_next;
    return x;
  });
}

double position_rms_error(const YieldingRecord& r, const std::vector<double>& x) {
  double sse = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sse += (x[i] - r.x_true[i]) * (x[i] - r.x_true[i]);
  return std::sqrt(sse / static_cast<double>(x.size()));
}

TEST(MotionEstimate, TheLoopModelTakesTheServosYieldToTheForceWhenGiven) {
  for (unsigned seed : {3u, 17u}) {
    const YieldingRecord r = yielding_record(seed);
    const MotionEstimate without = estimate_motion_with_reference(r.t, r.x, r.reference);
    const MotionEstimate with = estimate_motion_with_reference(r.t, r.x, r.reference, r.force);
    EXPECT_EQ(without.loop_force_taps, 0);
    EXPECT_EQ(with.loop_force_taps, 3);
    EXPECT_EQ(with.estimator, "rts_constant_acceleration_on_reference_and_force_loop_residual");
    // -1 / 20 000 N/m.
    EXPECT_NEAR(with.loop_force_response_m_per_n, -5e-5, 0.5e-5) << "seed " << seed;
    const double error_without = position_rms_error(r, without.position_m);
    const double error_with = position_rms_error(r, with.position_m);
    EXPECT_LT(error_with, 0.6 * error_without) << "seed " << seed << ": " << error_with << " m against " << error_without;
  }
}

// The loop model's regression over the padded channels: a position made
// exactly of a known response to a white reference and a white force, taps
// on both sides of the lag window's ends and the constant,
// is explained whole and its force response found to the last digits.
TEST(MotionEstimate, TheLoopRegressionFindsAKnownResponseExactly) {
  std::mt19937 rng(5);
  std::normal_distribution<double> white(0.0, 1.0);
  const std::size_t n = 6000;
  const double dt = 1e-3;  // 200 lag taps, 4 lead taps
  std::vector<double> t(n), r(n), f(n), x(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = dt * static_cast<double>(i);
    r[i] = 1e-6 * white(rng);
    f[i] = 1e-4 * white(rng);
  }
  const std::vector<std::pair<int, double>> reference_taps{{-4, 0.05}, {-1, 0.1}, {0, 0.3}, {3, 0.4}, {57, 0.2}, {200, -0.05}};
  const std::vector<double> force_taps{-2e-5, -1e-5, -0.5e-5};
  const auto clamped = [&](const std::vector<double>& v, long i) { return v[static_cast<std::size_t>(std::clamp<long>(i, 0, static_cast<long>(n) - 1))]; };
  for (std::size_t i = 0; i < n; ++i) {
    double value = r[0] + 3e-8;
    for (const auto& [k, h] : reference_taps) value += h * (clamped(r, static_cast<long>(i) - k) - r[0]);
    for (std::size_t k = 0; k < force_taps.size(); ++k) value += force_taps[k] * clamped(f, static_cast<long>(i) - static_cast<long>(k));
    x[i] = value;
  }
  const MotionEstimate m = estimate_motion_with_reference(t, x, r, f);
  ASSERT_EQ(m.loop_taps, 205);
  ASSERT_EQ(m.loop_force_taps, 3);
  EXPECT_GT(m.loop_variance_explained, 1.0 - 1e-12);
  EXPECT_NEAR(m.loop_force_response_m_per_n, -3.5e-5, 3.5e-5 * 1e-9);
}

// The loop model's normal equations: the tiled sum is the rank-one updates'
// sum bit for bit (the same products added in sample order), on windows of a
// random walk (nearly collinear columns, where the order of the sum shows in
// the last bits), 11 columns (not a whole number of tiles) and a constant.
TEST(MotionEstimate, TheGramMatrixIsTheRankOneUpdatesBitForBit) {
  std::mt19937 rng(7);
  std::normal_distribution<double> step(0.0, 1e-7);
  const std::size_t n = 5000;
  const int taps = 10;
  std::vector<double> walk(n + taps);
  for (std::size_t i = 1; i < walk.size(); ++i) walk[i] = walk[i - 1] + step(rng) + 3e-9;
  const std::vector<double> ones(n, 1.0);
  std::vector<const double*> columns;
  for (int c = 0; c < taps; ++c) columns.push_back(walk.data() + (taps - 1 - c));
  columns.push_back(ones.data());
  const auto cols = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(cols, cols);
  Eigen::VectorXd row(cols);
  for (std::size_t i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < cols; ++c) row[c] = columns[static_cast<std::size_t>(c)][i];
    expected.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  expected = expected.selfadjointView<Eigen::Lower>();
  const Eigen::MatrixXd gram = gram_in_sample_order(columns, n);
  ASSERT_EQ(gram.rows(), cols);
  ASSERT_EQ(gram.cols(), cols);
  for (Eigen::Index a = 0; a < cols; ++a) {
    for (Eigen::Index b = 0; b < cols; ++b) EXPECT_EQ(gram(a, b), expected(a, b)) << a << ", " << b;
  }
  // The same sum in blocks of samples (as a GEMM forms it) differs in the last bits here.
  Eigen::MatrixXd blocked = Eigen::MatrixXd::Zero(cols, cols);
  for (std::size_t first = 0; first < n; first += 1000) {
    Eigen::MatrixXd block = Eigen::MatrixXd::Zero(cols, cols);
    for (std::size_t i = first; i < first + 1000; ++i) {
      for (Eigen::Index c = 0; c < cols; ++c) row[c] = columns[static_cast<std::size_t>(c)][i];
      block.selfadjointView<Eigen::Lower>().rankUpdate(row);
    }
    blocked += block;
  }
  blocked = blocked.selfadjointView<Eigen::Lower>();
  EXPECT_NE(blocked, expected);
  // Shared out to threads, each tile still summed by one of them in sample order.
  for (unsigned threads : {0u, 2u, 3u}) EXPECT_EQ(gram_in_sample_order(columns, n, threads), expected) << threads << " threads";
}

// The setpoint's stretches start where its slope changes: the yielding
// record's twelve holds and twelve passes (0.5 s holds at 500 Hz: the first
// pass's first step is from sample 249 to 250).
TEST(MotionEstimate, TheSetpointStretchesStartWhereItsSlopeChanges) {
  const YieldingRecord r = yielding_record(3);
  const std::vector<std::size_t> starts = setpoint_stretches(r.t, r.reference);
  ASSERT_EQ(starts.size(), 24u);
  EXPECT_EQ(starts[0], 0u);
  EXPECT_EQ(starts[1], 249u);
  // The first pass: 4 um at 0.5 um/s, 8 s, 4000 samples.
  EXPECT_NEAR(static_cast<double>(starts[2] - starts[1]), 4000.0, 1.0);
  // A slope that changes by less than 2 % within a pass is one stretch.
  std::vector<double> ramp(r.reference.size());
  for (std::size_t i = 0; i < ramp.size(); ++i) ramp[i] = 1e-6 * r.t[i] * (1 + 0.005 * std::sin(r.t[i]));
  EXPECT_EQ(setpoint_stretches(r.t, ramp).size(), 1u);
}

// An intensity per stretch: in the holds the smoother keeps the tip still
// and on the plateaus at its speed, where one intensity for the record
// rounds the onsets off into both (Table 3.2's floors, the passes' own
// record as the setpoint; measured 2026-11-30: holds 9 nm/s RMS against 140,
// plateaus 1-2 nm/s against 76).
TEST(MotionEstimate, AnIntensityPerStretchKeepsTheHoldsStill) {
  for (unsigned seed : {1u, 2u}) {
    const Record r = noisy_record(seed);
    const MotionEstimate one = estimate_motion(r.t, r.x);
    const MotionEstimate per_stretch = estimate_motion_by_stretches(r.t, r.x, r.x_true);
    EXPECT_EQ(per_stretch.estimator, "rts_constant_acceleration_by_setpoint_stretches");
    double hold_one = 0, hold_stretch = 0;
    int holds = 0;
    for (std::size_t i = 0; i < r.t.size(); ++i) {
      if (r.v_true[i] != 0) continue;
      hold_one += one.velocity_m_per_s[i] * one.velocity_m_per_s[i];
      hold_stretch += per_stretch.velocity_m_per_s[i] * per_stretch.velocity_m_per_s[i];
      ++holds;
    }
    hold_one = std::sqrt(hold_one / holds);
    hold_stretch = std::sqrt(hold_stretch / holds);
    EXPECT_LT(hold_stretch, 0.5 * hold_one) << "seed " << seed << ": " << hold_stretch << " m/s against " << hold_one;
    EXPECT_LT(plateau_velocity_rms_error(r, per_stretch.velocity_m_per_s), 0.5 * plateau_velocity_rms_error(r, one.velocity_m_per_s))
        << "seed " << seed;
  }
}

// Both loop models from one normal-equation matrix (the diagnosis forms it
// once for the two): the same estimate, bit for bit, as each forming its own.
TEST(MotionEstimate, TheSharedLoopMatrixGivesEachLoopModelsOwnEstimate) {
  const YieldingRecord r = yielding_record(3);
  const std::optional<Eigen::MatrixXd> shared = loop_normal_matrix(r.t, r.reference, r.force, 2);
  ASSERT_TRUE(shared.has_value());
  EXPECT_EQ(shared->rows(), 105 + 3 + 1);  // 500 Hz: 4 lead and 100 lag taps, the force taps, the constant
  for (const bool with_force : {false, true}) {
    const std::vector<double> force = with_force ? r.force : std::vector<double>{};
    const MotionEstimate own = estimate_motion_with_reference(r.t, r.x, r.reference, force);
    const MotionEstimate from_shared = estimate_motion_with_reference(r.t, r.x, r.reference, force, false, {}, &*shared);
    EXPECT_EQ(from_shared.loop_taps, own.loop_taps);
    EXPECT_EQ(from_shared.loop_force_taps, with_force ? 3 : 0);
    EXPECT_EQ(from_shared.velocity_m_per_s, own.velocity_m_per_s) << (with_force ? "with" : "without") << " the force";
    EXPECT_EQ(from_shared.position_m, own.position_m) << (with_force ? "with" : "without") << " the force";
  }
  // No loop model on a record too short for one: no matrix.
  const std::vector<double> few(100, 0.0);
  EXPECT_FALSE(loop_normal_matrix(few, few, few, 1).has_value());
}

// A servo against a LuGre contact (as yielding_record) of any stiffness: the
// bristle's deflection z is stepped semi-implicitly, the tip moving the way
// the loop does, so a servo softer than the bristle stays stable.
YieldingRecord servo_against_contact(unsigned seed, double k_servo) {
  const double yield = kBristleN_per_m / k_servo;
  return servo_record(seed, [yield](double loop, double loop_step, double& z) {
    // dz = dx - |dx| z / g with dx = loop_step - yield dz, solved for dz.
    const double taken = 1 - (loop_step >= 0 ? z : -z) / kBristleG;
    z += loop_step * taken / (1 + yield * taken);
    return loop - yield * z;
  });
}

// servo_against_contact as the analysis reads it (no normal channel), its
// motion estimated by the loop model without the force or by the setpoint's
// stretches.
MeasuredSeries estimated(const YieldingRecord& r, ReferenceMotion motion) {
  MeasuredSeries s;
  s.source = "servo against a contact";
  s.time_s = r.t;
  s.position_m = r.x;
  s.reference_m = r.reference;
  s.force_n = r.force;
  derive_motion_smoothed(s, false, false, nullptr, motion);
  return s;
}

// The diagnosis' options for a CSV with a reference (analysis/fit_commands.cc).
DiagnosisOptions csv_with_reference() {
  DiagnosisOptions o;
  o.segmentation.segment_by_reference = true;
  o.choose_state_from_rest = true;
  o.threads = 1;
  return o;
}

// The motion estimate chosen by the base fit's held-out force error: on a
// servo stiffer than the contact (20 000 N/m against the bristle's 2000) the
// tip follows the setpoint through the 30 Hz loop, which the loop model
// describes, and the base predicts the held-out passes at the force noise
// (measured 2026-11-30, seeds 3 and 17: 1.59 and 1.50 uN against the
// stretches' 23.7 and 7.4, 1.2 and 3.8 standard errors above); on one ten
// times softer (200 N/m) the tip answers to the bristle, whose yield no one
// impulse response from the setpoint follows (the stretches 7.0 and 3.2 uN,
// the loop model 13.5 and 17.2, 5.6 and 2.5 standard errors above). With the
// comparison turned the other way every one of the four choices fails.
TEST(MotionEstimate, TheHeldOutForceChoosesTheLoopModelOnAStiffServoAndTheStretchesOnASoftOne) {
  for (unsigned seed : {3u, 17u}) {
    for (const double k_servo : {20000.0, 200.0}) {
      const YieldingRecord r = servo_against_contact(seed, k_servo);
      const MeasuredSeries loop = estimated(r, ReferenceMotion::loop_model);
      const MeasuredSeries stretches = estimated(r, ReferenceMotion::setpoint_stretches);
      const std::vector<MotionModelEvidence> e = weigh_motion_estimates({&loop, &stretches}, csv_with_reference());
      ASSERT_EQ(e.size(), 2u);
      EXPECT_EQ(e[0].estimator, loop.motion_estimator);
      EXPECT_EQ(e[1].estimator, stretches.motion_estimator);
      EXPECT_EQ(e[0].heldout_samples, e[1].heldout_samples);
      EXPECT_GT(e[0].heldout_samples, 0u);
      const bool stiff = k_servo > 2000;
      std::ostringstream where_stream;
      where_stream << "seed " << seed << ", " << k_servo << " N/m: held-out pass RMS " << e[0].heldout_pass_rms * 1e6
                   << " uN (loop model, " << e[0].heldout_excess_se << " SE) against " << e[1].heldout_pass_rms * 1e6
                   << " uN (stretches, " << e[1].heldout_excess_se << " SE)";
      const std::string where = where_stream.str();
      EXPECT_EQ(e[0].chosen, stiff) << where;
      EXPECT_EQ(e[1].chosen, !stiff) << where;
      // The chosen one predicts the held-out passes better, and the other
      // lies above it by at least a standard error of the difference.
      const MotionModelEvidence& chosen = e[stiff ? 0 : 1];
      const MotionModelEvidence& other = e[stiff ? 1 : 0];
      EXPECT_LT(chosen.heldout_pass_rms, other.heldout_pass_rms) << where;
      EXPECT_EQ(chosen.heldout_excess_se, 0.0) << where;
      EXPECT_GE(other.heldout_excess_se, 1.0) << where;
    }
  }
}

// Two estimates the held-out force cannot tell apart: the first (the loop
// model, the default) is kept.
TEST(MotionEstimate, TheDefaultMotionEstimateKeepsATieOnHeldOutForce) {
  const MeasuredSeries loop = estimated(servo_against_contact(3, 200.0), ReferenceMotion::loop_model);
  const std::vector<MotionModelEvidence> e = weigh_motion_estimates({&loop, &loop}, csv_with_reference());
  ASSERT_EQ(e.size(), 2u);
  EXPECT_TRUE(e[0].chosen);
  EXPECT_FALSE(e[1].chosen);
  EXPECT_EQ(e[0].heldout_pass_rms, e[1].heldout_pass_rms);
  EXPECT_EQ(e[1].heldout_excess_se, 0.0);
}

}  // namespace
}  // namespace tribo::analysis
