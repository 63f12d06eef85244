// The transducer's components one by one: the electrostatic drive (force law,
// calibration per side, handover, snap-down), the capacitive sensing chain
// (dC, linearisation, ADC, noise floors, drift) and the coloured noise.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <vector>

#include "sim/capacitive_sensor.h"
#include "sim/electrostatic_drive.h"
#include "sim/gauss_markov.h"
#include "sim/lateral_plant.h"
#include "sim/step_size.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

InstrumentParams defaults() { return instrument_params_from_config(testing::default_config().sim()); }

TEST(ElectrostaticDrive, PerfectlyCalibratedDrivePullsWithTheCommandedForceOnBothSides) {
  const ElectrostaticDriveParams p = defaults().lateral_drive;
  for (double x : {-10e-6, -1e-6, 0.0, 3e-6, 12e-6}) {
    for (double force : {-4e-3, -0.2e-3, 1e-6, 0.3e-3, 4e-3}) {
      DriveElectronics electronics(p);
      electronics.command(force, x, 1e-4);  // settle the driven side (a first handover)
      const DriveOutput out = electronics.command(force, x, 1e-4);
      ASSERT_EQ(out.dead_time_s, 0.0);
      EXPECT_NEAR(electrostatic_drive_field(p, out.voltages).force_n(x), force, 1e-12) << x << " " << force;
      EXPECT_NEAR(electronics.believed_force_n(out.voltages, x), force, 1e-12);
      // One plate at a time: the other sits at the bias.
      EXPECT_TRUE(out.voltages.positive_v == p.bias_voltage_v || out.voltages.negative_v == p.bias_voltage_v);
    }
  }
}

TEST(ElectrostaticDrive, ForceConstantsDifferPerSideAndAMiscalibratedSideIsOff) {
  ElectrostaticDriveParams p = defaults().lateral_drive;
  ASSERT_NE(p.plates.gap_positive_m, p.plates.gap_negative_m);
  DriveElectronics a(p), b(p);
  a.command(1e-3, 0, 1e-4);
  b.command(-1e-3, 0, 1e-4);
  const PlateVoltages pos = a.command(1e-3, 0, 1e-4).voltages, neg = b.command(-1e-3, 0, 1e-4).voltages;
  EXPECT_GT(neg.negative_v - p.bias_voltage_v, pos.positive_v - p.bias_voltage_v)
      << "the wider - gap needs more volts for the same force";
  // The electronics believe the - gap is 2 % narrower than it is: on that side
  // the true force is weaker; on the + side nothing changes.
  p.calibrated.gap_negative_m = 0.98 * p.plates.gap_negative_m;
  DriveElectronics c(p);
  c.command(-1e-3, 0, 1e-4);
  const DriveOutput out = c.command(-1e-3, 0, 1e-4);
  const double true_force = electrostatic_drive_field(p, out.voltages).force_n(0);
  EXPECT_NEAR(c.believed_force_n(out.voltages, 0), -1e-3, 1e-12);
  // The - plate was set to pull 1 mN plus the + plate's bias pull, but pulls
  // (d_cal / d)^2 = 0.9604 of that.
  const double bias_pos = plate_force_n(p.plates.area_m2, p.bias_voltage_v, p.plates.gap_positive_m);
  EXPECT_NEAR(true_force, bias_pos - 0.98 * 0.98 * (bias_pos + 1e-3), 1e-12);
  EXPECT_LT(std::fabs(true_force), 0.96e-3);
}

TEST(ElectrostaticDrive, HandoverLeavesOnlyTheBiasForTheHandoverTimeAtEveryLoopRate) {
  const ElectrostaticDriveParams p = defaults().lateral_drive;
  for (double dt : {1e-3, 1e-4, 2e-5}) {
    DriveElectronics e(p);
    e.command(1e-3, 2e-6, dt);
    e.command(1e-3, 2e-6, dt);
    double dead = 0;
    for (int k = 0; k < 20; ++k) {
      const DriveOutput out = e.command(-1e-3, 2e-6, dt);
      dead += out.dead_time_s;
      if (out.dead_time_s > 0) {
        EXPECT_EQ(out.bias.positive_v, p.bias_voltage_v);
        EXPECT_EQ(out.bias.negative_v, p.bias_voltage_v);
      }
    }
    EXPECT_NEAR(dead, p.handover_time_s, 1e-15) << "dt " << dt;
    EXPECT_EQ(e.driven_side(), -1);
  }
}

// Dissertation §5.1.1 (eqs. 16-19): one plate at voltage V, no contact. The plate is stable while
// k - eps0 A V^2 / (d - x)^3 > 0, which fails at x = d/3, reached at
// V_pi = sqrt(8 k d^3 / (27 eps0 A)). Ramping V slowly, the plate follows the
// static equilibrium x (d - x)^2 = eps0 A V^2 / (2 k) and snaps onto its stop
// within a few % of V_pi.
TEST(ElectrostaticDrive, SnapsDownAtThePullInVoltage) {
  InstrumentParams params = defaults();
  params.lateral.damping_n_s_per_m = 0.05;  // settle quickly in the quasi-static ramp
  const LateralPlant plant{params.lateral, params.friction};
  const ElectrostaticDriveParams& p = params.lateral_drive;
  const double k = params.lateral.spring_n_per_m, d = p.plates.gap_positive_m;
  const double eps_a = kVacuumPermittivity_f_per_m * p.plates.area_m2;
  const double v_pull_in = std::sqrt(8 * k * d * d * d / (27 * eps_a));
  // The smallest root of x (d - x)^2 = c, by bisection on [0, d/3].
  const auto equilibrium = [&](double v) {
    double lo = 0, hi = d / 3;
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      (mid * (d - mid) * (d - mid) < eps_a * v * v / (2 * k) ? lo : hi) = mid;
    }
    return lo;
  };
  LateralState s;
  LateralInputs in;
  double snapped_at_v = 0;
  bool checked_equilibrium = false;
  const int ramp_ticks = 40000;
  for (int tick = 0; tick < ramp_ticks && snapped_at_v == 0; ++tick) {
    const double v = 1.1 * v_pull_in * tick / ramp_ticks;
    in.drive = electrostatic_drive_field(p, PlateVoltages{v, 0});
    if (advance_lateral(plant, in, params.integrator, 1e-4, s).stopped) snapped_at_v = v;
    if (!checked_equilibrium && v >= 0.9 * v_pull_in) {
      checked_equilibrium = true;
      EXPECT_NEAR(s.position_m, equilibrium(v), 0.02 * equilibrium(v));
      EXPECT_GT(k - electrostatic_stiffness_n_per_m(p.plates, PlateVoltages{v, 0}, s.position_m), 0.0);
    }
  }
  ASSERT_GT(snapped_at_v, 0) << "no snap-down up to 1.1 V_pi = " << 1.1 * v_pull_in << " V";
  EXPECT_NEAR(snapped_at_v / v_pull_in, 1.0, 0.03) << "V_pi = " << v_pull_in << " V";
  EXPECT_NEAR(s.position_m, d - p.stop_gap_m, 1e-12) << "it sits on the stop";
  // And stays there while the voltage holds it, well below V_pi.
  in.drive = electrostatic_drive_field(p, PlateVoltages{0.5 * v_pull_in, 0});
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(advance_lateral(plant, in, params.integrator, 1e-4, s).stopped);
}

TEST(CapacitiveSensor, DifferentialCapacitanceFollowsEquation22) {
  const PlateGeometry g{1e-4, 100e-6, 100e-6};
  for (double x : {-20e-6, -1e-6, 0.0, 5e-6, 30e-6}) {
    const double expected = 2 * kVacuumPermittivity_f_per_m * 1e-4 * x / (100e-6 * 100e-6 - x * x);
    EXPECT_NEAR(differential_capacitance_f(g, x), expected, 1e-12 * std::fabs(expected) + 1e-30);
  }
}

TEST(CapacitiveSensor, LinearisationInvertsTheNonlinearCurve) {
  const PlateGeometry g = defaults().lateral_sensing.plates;
  const double gain = 5e12;
  for (double x = -40e-6; x <= 40e-6; x += 0.37e-6) {
    const double v = gain * differential_capacitance_f(g, x);
    EXPECT_NEAR(position_from_voltage_m(g, gain, v), x, 1e-17 + 1e-12 * std::fabs(x));
  }
  // The curve is nonlinear: 15 um reads 1.6 % high on a linear scale.
  const double slope = gain * capacitance_slope_f_per_m(g);
  EXPECT_GT(gain * differential_capacitance_f(g, 15e-6) / slope, 15.2e-6);
}

TEST(CapacitiveSensor, AdcQuantisesToItsStepAndClipsAtFullScale) {
  const Adc adc(24, 10.0);
  EXPECT_DOUBLE_EQ(adc.step_v, 20.0 / 16777216.0);
  const AdcSample s = digitise(1.23456789, adc);
  EXPECT_LE(std::fabs(s.voltage_v - 1.23456789), adc.step_v / 2);
  EXPECT_EQ(digitise(50.0, adc).counts, (1 << 23) - 1);
  EXPECT_EQ(digitise(-50.0, adc).counts, -(1 << 23));
}

// Table 3.2 floors, referred to position: white noise per sample, the
// low-frequency Gauss-Markov wander, and the thermal drift of the zero.
TEST(CapacitiveSensor, NoiseFloorsAndDriftAreWhatTheConfigSays) {
  const CapacitiveSensingParams base = defaults().lateral_sensing;
  const double dt = 1e-3;
  auto errors = [&](CapacitiveSensingParams p, int n) {
    CapacitivePositionSensor sensor(p, 1, 2);
    std::vector<double> e;
    for (int k = 1; k <= n; ++k) e.push_back(sensor.sample(0.0, k * dt, dt).position_m);
    return e;
  };
  auto rms = [](const std::vector<double>& e) {
    const double mean = std::accumulate(e.begin(), e.end(), 0.0) / static_cast<double>(e.size());
    double ss = 0;
    for (double x : e) ss += (x - mean) * (x - mean);
    return std::sqrt(ss / static_cast<double>(e.size()));
  };
  CapacitiveSensingParams white = base;
  white.low_frequency_noise_m = 0;
  white.drift_m_per_s = 0;
  white.white_noise_m = 1e-9;
  EXPECT_NEAR(rms(errors(white, 20000)), 1e-9, 0.03e-9);

  CapacitiveSensingParams low = base;
  low.white_noise_m = 0;
  low.drift_m_per_s = 0;
  low.adc_bits = 0;
  const std::vector<double> wander = errors(low, 400000);  // 400 s, 400 corner periods
  EXPECT_NEAR(rms(wander), base.low_frequency_noise_m, 0.1 * base.low_frequency_noise_m);
  // Smooth at the loop rate: a tick changes it by far less than its RMS.
  double step_sq = 0;
  for (std::size_t k = 1; k < wander.size(); ++k) step_sq += std::pow(wander[k] - wander[k - 1], 2);
  EXPECT_LT(std::sqrt(step_sq / static_cast<double>(wander.size())), 0.01 * base.low_frequency_noise_m);

  CapacitiveSensingParams drift = base;
  drift.white_noise_m = drift.low_frequency_noise_m = 0;
  drift.adc_bits = 0;
  drift.drift_m_per_s = 0.05e-9;
  EXPECT_NEAR(errors(drift, 100000).back(), 0.05e-9 * 100, 1e-12);
}

// The second-order process is discretised exactly: its variance and its
// autocorrelation (1 + w tau) exp(-w tau) are the same at any step.
TEST(GaussMarkov, SecondOrderStatisticsDoNotDependOnTheStep) {
  const double rms = 2.0, corner = 5.0, w = 2 * M_PI * corner, lag = 0.02;
  for (double dt : {1e-4, 1e-3, 5e-3}) {
    SecondOrderGaussMarkov n(rms, corner, 99);
    const int lag_steps = static_cast<int>(std::lround(lag / dt)), count = static_cast<int>(400.0 / dt);
    std::vector<double> v(static_cast<std::size_t>(count));
    for (double& x : v) x = n.advance(dt);
    double var = 0, cov = 0;
    for (int k = 0; k + lag_steps < count; ++k) {
      var += v[k] * v[k];
      cov += v[k] * v[k + lag_steps];
    }
    EXPECT_NEAR(std::sqrt(var / count), rms, 0.08 * rms) << dt;
    EXPECT_NEAR(cov / var, (1 + w * lag) * std::exp(-w * lag), 0.05) << dt;
  }
  FirstOrderGaussMarkov ou(3.0, 0.1, 5);
  double var = 0;
  for (int k = 0; k < 400000; ++k) var += std::pow(ou.advance(1e-3), 2);
  EXPECT_NEAR(std::sqrt(var / 400000), 3.0, 0.15);
}

}  // namespace
}  // namespace tribo::sim
