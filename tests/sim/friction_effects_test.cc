// The optional friction effects (sim/friction_effects.h), each against its
// documented equation -- the identification work uses them as ground truth.
// Most checks move the contact along a prescribed path (kinematically);
// the ones that involve the instrument (dwell, backlash, drift, wear) run
// the closed loop with noise-free sensors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "sim/friction_effects.h"
#include "sim/lateral_plant.h"
#include "sim/log_near_one.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

// The slip-rate solve's logarithm near a known one: within 1e-16 of
// std::log1p over its reach (the series' first term left out is 9e-17 at the
// ends), and exactly 0 at 0.
TEST(LogNearOne, MatchesLog1pOverItsReach) {
  EXPECT_EQ(log_near_one(0.0), 0.0);
  double worst = 0;
  for (int i = -4000; i <= 4000; ++i) {
    const double d = kLogNearOneReach * i / 4000.0;
    worst = std::max(worst, std::fabs(log_near_one(d) - std::log1p(d)));
  }
  EXPECT_LT(worst, 1e-16);
  // Twice the reach the series is visibly short: the reach is what it is for.
  EXPECT_GT(std::fabs(log_near_one(-2 * kLogNearOneReach) - std::log1p(-2 * kLogNearOneReach)), 1e-15);
}

// The plant under test is declared: plain LuGre (tests/sim/sim_test_support.h),
// not the default instrument.
using testing::plain_lugre_config;
using testing::LoopSetpoints;

InstrumentParams defaults() { return instrument_params_from_config(plain_lugre_config().sim()); }

// The contact alone, the tip moved along a prescribed path; the contact
// states are integrated with explicit steps far below their time constants.
class Kinematic {
 public:
  Kinematic(const FrictionModel& m, double load_n) {
    plant_.axis = defaults().lateral;
    plant_.friction = m;
    in_.drive = ideal_drive_field(0);
    in_.levels = contact_levels(m, load_n, 0, 1);
  }
  // Moves at velocity v for the given time; returns the friction at the end.
  double move(double v, double duration_s) {
    const double g_min = std::min(in_.levels.static_n, in_.levels.coulomb_n) * modulation_floor(plant_.friction) *
                         (plant_.friction.presliding_hysteresis.enabled ? 1 - plant_.friction.presliding_hysteresis.spread : 1) /
                         plant_.friction.lugre.sigma0_n_per_m;
    double h = v != 0 ? std::min(1e-4, g_min / (200 * std::fabs(v))) : 1e-4;
    if (plant_.friction.frictional_lag.enabled) h = std::min(h, plant_.friction.frictional_lag.time_constant_s / 100);
    const long steps = std::max(1L, std::lround(duration_s / h));
    h = duration_s / static_cast<double>(steps);
    s_.velocity_m_per_s = s_.tip_velocity_m_per_s = v;
    for (long i = 0; i < steps; ++i) {  // Heun's method on the contact states
      const LateralRate r1 = lateral_derivative(plant_, in_, s_).rate;
      LateralState mid = s_;
      advance(mid, r1, h, v);
      const LateralRate r2 = lateral_derivative(plant_, in_, mid).rate;
      advance(s_, r1, h / 2, v);
      advance(s_, r2, h / 2, v);
    }
    return friction();
  }
  // Moves by dx at speed |v|.
  double move_by(double dx, double speed) { return move(dx > 0 ? speed : -speed, std::fabs(dx) / speed); }
  double friction() const { return lateral_derivative(plant_, in_, s_).friction_n; }
  const LateralState& state() const { return s_; }
  const FrictionLevels& levels() const { return in_.levels; }

 private:
  void advance(LateralState& s, const LateralRate& r, double h, double v) const {
    s.position_m += v * h;
    s.tip_position_m = s.position_m;
    s.bristle_m += h * r.bristle_m;
    s.lag_velocity_m_per_s += h * r.lag_velocity_m_per_s;
    s.contact_age_s += h * r.contact_age_s;
    const auto& hy = plant_.friction.presliding_hysteresis;
    for (int k = 0; hy.enabled && k < hy.elements; ++k) s.slip_m[k] += h * r.slip_m[k];
  }

  LateralPlant plant_;
  LateralInputs in_;
  LateralState s_;
};

TEST(FrictionEffects, VelocityStrengtheningAddsALogarithmicRise) {
  FrictionModel m = defaults().friction;
  m.velocity_strengthening = {true, 0.002, 0.1e-6};
  const double load = 2e-3;
  for (double v : {0.5e-6, 4e-6, 40e-6}) {
    Kinematic k(m, load);
    const double f = k.move(v, 60 * 3e-8 / v + 0.05);
    const double fc = m.lugre.coulomb_coeff * load, fs = m.lugre.static_coeff * load;
    const double expected = fc + (fs - fc) * std::exp(-v / m.lugre.stribeck_velocity_m_per_s) +
                            0.002 * load * std::log1p(v / 0.1e-6) + m.lugre.sigma2_n_s_per_m * v;
    EXPECT_NEAR(f, expected, 1e-4 * expected) << v;
  }
}

TEST(FrictionEffects, LoadDependenceFollowsTheContactArea) {
  FrictionModel m = defaults().friction;
  m.load_dependence = {true, 0.0, 2.0 / 3.0, 3e-3};
  // N^(2/3): eight times the load, four times the friction.
  EXPECT_NEAR(contact_levels(m, 8e-3, 0, 1).coulomb_n / contact_levels(m, 1e-3, 0, 1).coulomb_n, 4.0, 1e-12);
  EXPECT_NEAR(contact_levels(m, 3e-3, 0, 1).coulomb_n, m.lugre.coulomb_coeff * 3e-3, 1e-15) << "equal at N_ref";
  // Adhesion: friction at vanishing load is mu times the adhesion load.
  m.load_dependence = {true, 200e-6, 1.0, 3e-3};
  EXPECT_NEAR(contact_levels(m, 1e-9, 0, 1).coulomb_n, m.lugre.coulomb_coeff * (200e-6 + 1e-9), 1e-15);
}

TEST(FrictionEffects, OrientationAnisotropyIsSinusoidalInTheSampleRotation) {
  FrictionModel m = defaults().friction;
  m.orientation_anisotropy = {true, 0.15, 360, 270};
  const double top = contact_levels(m, 1e-3, 270, 1).coulomb_n, bottom = contact_levels(m, 1e-3, 90, 1).coulomb_n;
  EXPECT_NEAR(top / bottom, 1.15 / 0.85, 1e-12);
  EXPECT_NEAR(contact_levels(m, 1e-3, 0, 1).coulomb_n, contact_levels(m, 1e-3, 180, 1).coulomb_n, 1e-15)
      << "0 and 180 deg agree (Fig. 4.29)";
}

TEST(FrictionEffects, DirectionAsymmetryScalesEachDirection) {
  FrictionModel m = defaults().friction;
  m.direction_asymmetry = {true, 0.05};
  Kinematic forward(m, 2e-3), backward(m, 2e-3);
  const double f = forward.move(4e-6, 0.3), b = backward.move(-4e-6, 0.3);
  EXPECT_NEAR(f / -b, 1.05 / 0.95, 1e-3);
}

// The bristle follows g(x) through a first-order filter in space of length
// g0 = S0 / sigma0 (dz/dx = 1 - z / g for v > 0), so the friction's ripple at
// the lattice period is a S0 / sqrt(1 + (2 pi g0 / lambda)^2).
TEST(FrictionEffects, PositionPeriodicFrictionFollowsTheLattice) {
  FrictionModel m = defaults().friction;
  const double amplitude = 0.1, period = 0.5e-6, v = 4e-6;
  m.position_periodic = {true, amplitude, period, 0.0};
  Kinematic k(m, 2e-3);
  k.move(v, 0.05);  // settle
  const FrictionModel plain = defaults().friction;
  const double s0 = steady_state_friction_n(plain, contact_levels(plain, 2e-3, 0, 1), v, 0) - plain.lugre.sigma2_n_s_per_m * v;
  double sin_sum = 0, cos_sum = 0, mean = 0;
  const int samples = 200;  // four periods
  for (int i = 0; i < samples; ++i) {
    const double f = k.move(v, 4 * period / samples / v);
    const double phase = 2 * std::numbers::pi * k.state().position_m / period;
    sin_sum += f * std::sin(phase);
    cos_sum += f * std::cos(phase);
    mean += f;
  }
  const double ripple = 2 * std::hypot(sin_sum, cos_sum) / samples;
  const double g0 = s0 / plain.lugre.sigma0_n_per_m, kg = 2 * std::numbers::pi * g0 / period;
  EXPECT_NEAR(mean / samples, s0, 0.01 * s0);
  EXPECT_NEAR(ripple, amplitude * s0 / std::sqrt(1 + kg * kg), 0.1 * amplitude * s0);
}

TEST(FrictionEffects, FrictionalLagDelaysTheStribeckCurveButNotTheSteadyState) {
  FrictionModel m = defaults().friction;
  m.frictional_lag = {true, 5e-3};
  Kinematic lagged(m, 2e-3), prompt(defaults().friction, 2e-3);
  lagged.move(0.5e-6, 0.4);
  prompt.move(0.5e-6, 0.4);
  EXPECT_NEAR(lagged.friction(), prompt.friction(), 1e-5 * prompt.friction()) << "same steady state";
  // A step to 4 um/s: 5 ms later the lagged curve has moved 1 - 1/e of the way.
  const double before = prompt.friction();
  lagged.move(4e-6, 5e-3);
  const double settled = steady_state_friction_n(defaults().friction, prompt.levels(), 4e-6, 0);
  const double expected_vl = 4e-6 - (4e-6 - 0.5e-6) * std::exp(-1.0);
  EXPECT_NEAR(lagged.state().lag_velocity_m_per_s, expected_vl, 0.01 * expected_vl);
  EXPECT_GT(lagged.friction(), settled + 0.2 * (before - settled)) << "still on its way down";
}

// Return-point memory (Masing): going 0 -> A -> B -> A within presliding, the
// Maxwell-slip set comes back to the force it had at A; one LuGre bristle does not.
TEST(FrictionEffects, PreslidingHysteresisHasReturnPointMemory) {
  FrictionModel gms = defaults().friction;
  gms.presliding_hysteresis = {true, 6, 0.7, 0.9};
  const double load = 2e-3, g = contact_levels(gms, load, 0, 1).static_n / gms.lugre.sigma0_n_per_m;
  const double a = 0.9 * g, b = 0.2 * g, speed = 0.2e-6;
  auto memory_error = [&](const FrictionModel& m) {
    Kinematic k(m, load);
    const double at_a = k.move_by(a, speed);
    k.move_by(b - a, speed);
    const double back_at_a = k.move_by(a - b, speed);
    return std::fabs(back_at_a - at_a) / std::fabs(at_a);
  };
  const double with_elements = memory_error(gms), plain = memory_error(defaults().friction);
  EXPECT_LT(with_elements, 0.01);
  EXPECT_GT(plain, 3 * with_elements);
  // And sliding is unchanged: F = S(v) + sigma2 v.
  Kinematic k(gms, load);
  const double f = k.move(4e-6, 0.1);
  EXPECT_NEAR(f, steady_state_friction_n(defaults().friction, k.levels(), 4e-6, 0), 1e-4 * f);
}

// Closed loop, noise-free sensors.
v1::DaemonConfig quiet() {
  v1::DaemonConfig config = plain_lugre_config();
  testing::silence_sensors(config);
  return config;
}

// Rest under 2 mN for rest_s, then pull at 4 um/s: the highest friction in
// the first 0.3 s of motion.
double stiction_peak(const v1::DaemonConfig& config, double rest_s) {
  double peak = 0;
  const double t_go = 0.4 + rest_s;
  testing::run_closed_loop(config, 1, t_go + 0.3,
                           [&](double t) {
                             return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * 2e-3,
                                                  2e-6 * std::min(1.0, t / 0.1) + (t > t_go ? 4e-6 * (t - t_go) : 0)};
                           },
                           [&](double t, const hal::SimTransducer& tr) {
                             if (t > t_go) peak = std::max(peak, tr.instrument().truth().friction_n);
                           });
  return peak;
}

TEST(FrictionEffects, DwellMakesTheStictionSpikeGrowWithRestTime) {
  v1::DaemonConfig config = quiet();
  // No tilt: its push, shared by bristle and loop while the loop's integrator
  // settles (kp/ki = 0.2 s), would make the spike depend on the rest as well.
  config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  // After loading, the stuck tip still settles under the loop's integrator
  // (time constant ~ (kp + k + sigma0) / ki = 0.7 s): from 4 s on, plain
  // LuGre no longer depends on the rest.
  const double plain_short = stiction_peak(config, 0.5), plain_settled = stiction_peak(config, 4),
               plain_long = stiction_peak(config, 8);
  EXPECT_NEAR(plain_long, plain_settled, 2e-3 * plain_settled) << "plain LuGre forgets the rest";
  auto* dwell = config.mutable_sim()->mutable_friction()->mutable_dwell_stiction();
  dwell->set_enabled(true);
  dwell->set_gain(0.5);
  dwell->set_time_constant_s(1.0);
  const double short_rest = stiction_peak(config, 0.5), long_rest = stiction_peak(config, 8);
  // Static friction after a contact age theta (from the first touch, 0.1 s):
  // Fs (1 + gain theta / (theta + gamma)); the spike rises with it, by a
  // share of Fs's rise (the spike is below Fs), on top of the loop's own
  // settling (plain_long / plain_short).
  const double fs_ratio = (1 + 0.5 * 8.3 / 9.3) / (1 + 0.5 * 0.8 / 1.8);
  const double grew = (long_rest / short_rest) / (plain_long / plain_short);
  std::printf("  stiction peak %.1f uN after 0.5 s, %.1f uN after 8 s (plain LuGre %.1f, %.1f uN); Fs grew %.1f %%\n",
              short_rest * 1e6, long_rest * 1e6, plain_short * 1e6, plain_long * 1e6, 100 * (fs_ratio - 1));
  EXPECT_GT(grew, 1 + 0.25 * (fs_ratio - 1));
  EXPECT_LT(grew, fs_ratio + 1e-3);
}

// In steady sliding the coupling is engaged: the plate leads the tip by half
// the play plus the coupling's compression F / k_b, on either side.
TEST(FrictionEffects, BacklashSeparatesPlateAndTipByThePlayAndTheCoupling) {
  v1::DaemonConfig config = quiet();
  config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  auto* b = config.mutable_sim()->mutable_tip()->mutable_backlash();
  b->set_enabled(true);
  double forward = 0, backward = 0, friction_forward = 0, friction_backward = 0;
  // 2 mN; +2 -> +3 um at 1 um/s, then back; sample the last 0.2 s of each way.
  testing::run_closed_loop(config, 1, 2.5,
                           [](double t) {
                             const double x = t < 0.5 ? 0 : (t < 1.5 ? t - 0.5 : std::max(0.0, 2.5 - t));
                             return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * 2e-3, 2e-6 * std::min(1.0, t / 0.1) + 1e-6 * x};
                           },
                           [&](double t, const hal::SimTransducer& tr) {
                             const LateralState& s = tr.instrument().truth().lateral;
                             if (t > 1.3 && t <= 1.5) {
                               forward = s.position_m - s.tip_position_m;
                               friction_forward = tr.instrument().truth().friction_n;
                             }
                             if (t > 2.3) {
                               backward = s.position_m - s.tip_position_m;
                               friction_backward = tr.instrument().truth().friction_n;
                             }
                           });
  const double half_play = 0.5 * b->width_m(), k_b = b->coupling_stiffness_n_per_m();
  EXPECT_NEAR(forward, half_play + friction_forward / k_b, 0.05 * half_play);
  EXPECT_NEAR(backward, -half_play + friction_backward / k_b, 0.05 * half_play);
}

// Held at 7 mN, the sample creeping at r = 1 nm/s from 1.5 s to 10.5 s,
// compared with the same run without creep (the loop is still settling from
// the load ramp in both). Relative to the sample the tip moves at -r, so the
// bristle loads elastically (-r) and, LuGre having no true stiction, also
// relaxes: dz/dt = -r (1 + z / g). The lateral force therefore drops by more
// than sigma0 r t, and by less than if the tip were held rigidly,
// sigma0 (z0 + g)(1 - exp(-r t / g)) with g = Fs / sigma0, because the loop
// gives a little.
TEST(FrictionEffects, SampleCreepMakesTheHeldLateralForceDrift) {
  v1::DaemonConfig config = quiet();
  config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  double z0 = 0, g = 0;
  auto change = [&](const v1::DaemonConfig& c, double* offset) {
    double at_start = 0, at_end = 0;
    testing::run_closed_loop(c, 1, 10.5,
                             [](double t) {
                               return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * 7e-3, 2e-6 * std::min(1.0, t / 0.1)};
                             },
                             [&](double t, const hal::SimTransducer& tr) {
                               const InstrumentTruth& truth = tr.instrument().truth();
                               if (std::fabs(t - 1.5) < 5e-5) {
                                 at_start = tr.instrument().measurement().lateral_force_n;
                                 z0 = truth.lateral.bristle_m;
                                 g = truth.levels.static_n / c.sim().friction().contact_stiffness_n_per_m();
                               }
                               at_end = tr.instrument().measurement().lateral_force_n;
                               if (offset) *offset = truth.sample_offset_m;
                             });
    return at_end - at_start;
  };
  const double settling = change(config, nullptr);
  auto* d = config.mutable_sim()->mutable_sample()->mutable_drift();
  d->set_enabled(true);
  d->set_rate_m_per_s(1e-9);
  d->set_velocity_rms_m_per_s(0);
  double offset = 0;
  const double with_creep = change(config, &offset);
  EXPECT_NEAR(offset, 10.5e-9, 1e-13);
  const double sigma0 = config.sim().friction().contact_stiffness_n_per_m();
  const double rigid = sigma0 * (z0 + g) * std::expm1(-1e-9 * 9 / g);
  std::printf("  lateral force drift %.1f uN; elastic share %.1f uN, rigidly held tip %.1f uN\n",
              (with_creep - settling) * 1e6, -sigma0 * 9e-9 * 1e6, rigid * 1e6);
  EXPECT_LT(with_creep - settling, -1.1 * sigma0 * 9e-9) << "more than the elastic share alone";
  EXPECT_GT(with_creep - settling, rigid);
}

// A tip dragged under 5 mN, stopped, then unloaded to zero over 2 s (noise-free
// sensors: nothing else relaxes the contact). The held force may not exceed
// what the falling load holds, mu_s N: it releases with the load. Plain LuGre
// kept it (627 uN at 1 mN of load, mu_s N = 143 uN) and let go only when
// contact was lost.
void unload_while_stuck(bool maxwell_slip) {
  v1::DaemonConfig config = quiet();
  config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  config.mutable_sim()->mutable_friction()->mutable_presliding_hysteresis()->set_enabled(maxwell_slip);
  const double load = 5e-3, mu_s = config.sim().friction().static_coeff();
  double worst_ratio = 0, force_at_1mn = NAN;
  testing::run_closed_loop(config, 1, 7.0,
                           [&](double t) {
                             const double unload = std::clamp((t - 4.5) / 2.0, 0.0, 1.0);
                             return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * load * (1 - unload),
                                                  2e-6 + 2e-6 * std::clamp(t - 1.0, 0.0, 1.5)};
                           },
                           [&](double t, const hal::SimTransducer& tr) {
                             const InstrumentTruth& truth = tr.instrument().truth();
                             if (t < 4.5 || !truth.levels.in_contact()) return;
                             double z = truth.lateral.bristle_m;
                             if (maxwell_slip) {  // element stiffness sigma0 / n
                               const int n = config.sim().friction().presliding_hysteresis().elements();
                               z = 0;
                               for (int i = 0; i < n; ++i) z += truth.lateral.slip_m[i] / n;
                             }
                             const double held = config.sim().friction().contact_stiffness_n_per_m() * std::fabs(z);
                             worst_ratio = std::max(worst_ratio, held / truth.levels.static_n);
                             if (std::isnan(force_at_1mn) && truth.normal.contact_load_n < 1e-3) {
                               force_at_1mn = tr.instrument().measurement().lateral_force_n;
                             }
                           });
  std::printf("  %s: held force at most %.3f mu_s N while unloading; %.1f uN at 1 mN (mu_s N %.1f uN)\n",
              maxwell_slip ? "Maxwell slip" : "LuGre", worst_ratio, force_at_1mn * 1e6, mu_s * 1e-3 * 1e6);
  EXPECT_LE(worst_ratio, 1 + 1e-9);
  EXPECT_GT(worst_ratio, 0.9) << "the held force met the falling limit";
  EXPECT_NEAR(force_at_1mn, mu_s * 1e-3, 0.05 * mu_s * 1e-3);
}

TEST(FrictionEffects, UnloadingReleasesAHeldForceWithTheLoad) { unload_while_stuck(false); }
TEST(FrictionEffects, UnloadingReleasesAHeldForceWithTheLoadMaxwellSlip) { unload_while_stuck(true); }

// Fig. 3.12 (a tip held 1000 s at 7000 uN drifts by +-300 uN) needs a contact
// that holds a static force. With the sensors' noise on, the tip follows the
// position wander (3 nm RMS, 0.3 Hz) and plain LuGre's bristle slips on every
// nanometre of it: the held force drains, and creep cannot build up. The
// elasto-plastic contact (breakaway_ratio, sim/lugre_friction.h) is elastic
// there and shows the creep. Why the diagnosis does not see the sample's
// creep on a run of the plain sim: docs/identification.md, "Tests on tribo's
// simulated instrument and on synthetic runs".
struct HeldForce {
  double start_n = 0, end_n = 0, creep_m = 0;  // force means over 2-3 s and 102-103 s
};

HeldForce hold_at_7mn(v1::DaemonConfig config, double breakaway_ratio, bool creep) {
  config.mutable_sim()->mutable_tip()->mutable_tilt_offset()->set_enabled(false);
  config.mutable_sim()->mutable_friction()->set_breakaway_ratio(breakaway_ratio);
  // Fig. 3.12's ~100 nm of creep in 100 s instead of 1000 s (CPU time).
  auto* d = config.mutable_sim()->mutable_sample()->mutable_drift();
  d->set_enabled(creep);
  d->set_rate_m_per_s(1e-9);
  d->set_velocity_rms_m_per_s(0);
  HeldForce h;
  int n_start = 0, n_end = 0;
  testing::run_closed_loop(config, 1, 103,
                           [](double t) {
                             return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * 7e-3, 2e-6 * std::min(1.0, t / 0.1)};
                           },
                           [&](double t, const hal::SimTransducer& tr) {
                             const double f = tr.instrument().measurement().lateral_force_n;
                             if (t >= 2 && t < 3) h.start_n += f, ++n_start;
                             if (t >= 102 && t < 103) h.end_n += f, ++n_end;
                             h.creep_m = tr.instrument().truth().sample_offset_m;
                           });
  h.start_n /= n_start;
  h.end_n /= n_end;
  return h;
}

TEST(FrictionEffects, OnlyAnElasticContactHoldsItsForceAndShowsTheCreep) {
  const double sigma0 = plain_lugre_config().sim().friction().contact_stiffness_n_per_m();
  const HeldForce silent = hold_at_7mn(quiet(), 0, false), plain = hold_at_7mn(plain_lugre_config(), 0, false),
                  plain_creep = hold_at_7mn(plain_lugre_config(), 0, true), elastic = hold_at_7mn(plain_lugre_config(), 0.8, false),
                  elastic_creep = hold_at_7mn(plain_lugre_config(), 0.8, true);
  const double rigid = sigma0 * elastic_creep.creep_m;  // a rigidly held tip on an elastic contact
  auto drifted = [](const HeldForce& with, const HeldForce& without) {
    return (with.end_n - with.start_n) - (without.end_n - without.start_n);
  };
  std::printf("  held force 2 s -> 102 s: silent sensors %.0f -> %.0f uN, plain %.0f -> %.0f uN, elastic %.0f -> %.0f uN\n",
              silent.start_n * 1e6, silent.end_n * 1e6, plain.start_n * 1e6, plain.end_n * 1e6, elastic.start_n * 1e6,
              elastic.end_n * 1e6);
  std::printf("  creep %.1f nm (sigma0 x creep %.0f uN): drift plain %.0f uN, elastic %.0f uN\n", elastic_creep.creep_m * 1e9,
              rigid * 1e6, drifted(plain_creep, plain) * 1e6, drifted(elastic_creep, elastic) * 1e6);
  ASSERT_GT(silent.start_n, 500e-6);  // stuck after the approach, below Fs = 1000 uN
  EXPECT_GT(silent.end_n, 0.9 * silent.start_n) << "without the wander the stuck contact holds";
  EXPECT_LT(plain.end_n, 0.1 * plain.start_n) << "plain LuGre drains under the wander";
  EXPECT_GT(elastic.end_n, 0.7 * elastic.start_n) << "the elasto-plastic contact holds";
  EXPECT_GT(-drifted(plain_creep, plain), 0) << "the creep pushes the force down (tip moves -r relative to the sample)";
  EXPECT_LT(-drifted(plain_creep, plain), 0.2 * rigid) << "drained by plain LuGre";
  EXPECT_GT(-drifted(elastic_creep, elastic), 0.7 * rigid) << "shown by the elastic contact";
  EXPECT_LT(-drifted(elastic_creep, elastic), rigid) << "the loop gives a little";
}

TEST(FrictionEffects, RepeatedScratchesReachASteadyState) {
  v1::DaemonConfig config = quiet();
  auto* w = config.mutable_sim()->mutable_sample()->mutable_wear();
  w->set_enabled(true);
  // Four passes over +2..+6 um at 2 um/s under 5 mN (the I-PD loop lags
  // 0.4 um behind at this speed); friction averaged where the tip crosses
  // the middle of the track, 3.5..4.5 um.
  const double load = 5e-3, v = 2e-6, travel = 4e-6, pass_s = travel / v, t0 = 0.5;
  std::vector<double> middle(4, 0.0), levels(4, 0.0);
  std::vector<int> count(4, 0);
  testing::run_closed_loop(config, 1, t0 + 4 * pass_s,
                           [&](double t) {
                             const double s = std::max(0.0, t - t0) / pass_s;
                             const double phase = s - 2 * std::floor(s / 2);  // 0..2: out and back
                             const double x = travel * (phase < 1 ? phase : 2 - phase);
                             return LoopSetpoints{std::clamp((t - 0.1) / 0.3, 0.0, 1.0) * load, 2e-6 * std::min(1.0, t / 0.1) + x};
                           },
                           [&](double t, const hal::SimTransducer& tr) {
                             const double x = tr.instrument().truth().lateral.position_m;
                             if (t < t0 || x < 3.5e-6 || x > 4.5e-6) return;
                             const int pass = std::min(3, static_cast<int>((t - t0) / pass_s));
                             middle[pass] += std::fabs(tr.instrument().truth().friction_n);
                             levels[pass] += tr.instrument().truth().levels.coulomb_n;
                             ++count[pass];
                           });
  // Pass n (from 0) slides over track worn n times: W = 1 - (1 - ratio)(1 - exp(-kappa n)).
  const double kappa = w->decay_per_pass() * std::pow(load / w->reference_load_n(), w->load_exponent());
  for (int n = 1; n < 4; ++n) {
    ASSERT_GT(count[n], 100);
    const double expected = 1 - (1 - w->steady_state_ratio()) * (1 - std::exp(-kappa * n));
    EXPECT_NEAR((levels[n] / count[n]) / (levels[0] / count[0]), expected, 1e-4) << "pass " << n;
    // The friction follows (within the loop's velocity ripple in the Stribeck region).
    EXPECT_NEAR((middle[n] / count[n]) / (middle[0] / count[0]), expected, 0.015) << "pass " << n;
  }
}

}  // namespace
}  // namespace tribo::sim
