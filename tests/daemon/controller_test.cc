// The control modes, mode switches and gain changes on the simulated
// instrument, through the real-time loop.
#include "daemon/controller.h"

#include <gtest/gtest.h>

#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

using testing::mean_between;
using testing::parse_protocol;
using testing::run_in_loop;

// Open loop, the normal springs absorb part of the command (dissertation §3);
// closed loop holds the measured contact force itself.
TEST(Controller, ClosedLoopNormalForceHoldsTheLoadThatOpenLoopMisses) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const auto hold = [&](const char* mode) {
    return run_in_loop(config, parse_protocol(std::string(R"(
      segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
      segments { duration_s: 1 normal { mode: )") + mode + R"( end_uN: 1000 } lateral { shape: HOLD } }
      segments { duration_s: 2 normal { mode: )" + mode + R"( shape: HOLD } lateral { shape: HOLD } }
      segments { duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
    )"));
  };
  const auto open = hold("NORMAL_OPEN_LOOP_FORCE");
  const auto closed = hold("NORMAL_CLOSED_LOOP_FORCE");
  const double open_n = mean_between(open.samples, 2.5, 4, &Sample::normal_force_n);
  const double closed_n = mean_between(closed.samples, 2.5, 4, &Sample::normal_force_n);
  EXPECT_NEAR(open_n, 996.7e-6, 0.2e-6) << "100 N/m springs absorb 0.33 % at 1 mN";
  // 15000 samples of 100 nN noise: the mean is good to ~1 nN.
  EXPECT_NEAR(closed_n, 1000e-6, 0.02e-6);
  EXPECT_EQ(closed.outcome.end, RunEnd::kCompleted);
  for (const Sample& s : closed.samples) {
    if (s.time_s >= 1 && s.time_s < 4) {
      ASSERT_TRUE(s.status_flags & v1::NORMAL_CLOSED_LOOP) << s.time_s;
    }
  }
}

TEST(Controller, NormalDisplacementModeHoldsTheIndentation) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const auto run = run_in_loop(config, parse_protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { duration_s: 1 normal { end_uN: 500 } lateral { shape: HOLD } }
    segments { duration_s: 1 normal { mode: NORMAL_DISPLACEMENT end_um: 0.05 } lateral { shape: HOLD } }
    segments { duration_s: 2 normal { mode: NORMAL_DISPLACEMENT shape: HOLD } lateral { shape: HOLD } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
  )"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted);
  EXPECT_NEAR(mean_between(run.samples, 4, 5, &Sample::normal_displacement_m), 50e-9, 0.5e-9);
  // The contact force that 50 nm of Hertz indentation takes (E* = 18 GPa, R = 50 µm): ~1.9 mN.
  const double load = mean_between(run.samples, 4, 5, &Sample::normal_force_n);
  EXPECT_NEAR(load, 4.0 / 3.0 * 18e9 * std::sqrt(50e-6) * std::pow(50e-9, 1.5), 0.05e-3);
}

// A lateral force ramp in LATERAL_FORCE: the measured force follows the
// setpoint until the tip breaks away; then the axis holds its position.
TEST(Controller, LateralForceControlTracksTheRampThenHoldsAfterBreakAway) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const auto run = run_in_loop(config, testing::load_protocol_file("breakaway.textproto"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted) << trip_description(run.outcome.trip);
  // Force ramp: t = 9..14 s, 0 -> 1500 µN at 300 µN/s. Before break-away the
  // measured force (1 kHz averages of 10 µN noise) is on the ramp.
  double worst = 0, breakaway_t = 0, peak = 0;
  for (const Sample& s : run.samples) {
    if (s.segment_index != 3) continue;
    if (s.status_flags & v1::BREAKAWAY_HOLD) {
      if (breakaway_t == 0) breakaway_t = s.time_s;
      continue;
    }
    ASSERT_TRUE(s.status_flags & v1::LATERAL_FORCE_CONTROL);
    if (s.time_s > 9.01) worst = std::max(worst, std::fabs(s.lateral_force_n - 300e-6 * (s.time_s - 9.0)));
    peak = std::max(peak, s.lateral_force_n);
  }
  EXPECT_LT(worst, 15e-6) << "the measured force follows the setpoint";
  ASSERT_GT(breakaway_t, 9.0) << "no break-away";
  // Plain LuGre breaks away between its Coulomb and static levels, at a
  // force that depends on the force rate: between 0.0996 and 0.1427 x 4990 µN
  // of friction. The tilted tip reads friction - N tan(theta) pushing
  // towards +x (the setpoint is the reading, so the tip carries more).
  ASSERT_TRUE(config.sim().tip().tilt_offset().enabled());
  const double tilt_n = 4990e-6 * std::tan(config.sim().tip().tilt_offset().angle_deg() * M_PI / 180);
  EXPECT_GT(peak + tilt_n, 0.0996 * 4990e-6);
  EXPECT_LT(peak + tilt_n, 0.1427 * 4990e-6);
  // Held after break-away at the point where it broke away (the hold
  // setpoint). The default contact's friction drops after break-away and the
  // tip overshoots that point (by 0.2 um here; §5.3.1); the displacement loop
  // (Table 5.1's gains) brings it back within about a second, against the
  // contact. Then within 50 nm of the setpoint (3.2 nm RMS of record noise).
  double overshoot = 0;
  for (const Sample& s : run.samples) {
    if (s.segment_index != 3 || s.time_s <= breakaway_t) continue;
    overshoot = std::max(overshoot, s.lateral_position_m - s.lateral_setpoint_m);
    if (s.time_s > breakaway_t + 1.5) {
      EXPECT_NEAR(s.lateral_position_m, s.lateral_setpoint_m, 50e-9) << s.time_s;
    }
  }
  EXPECT_LT(overshoot, 0.5e-6) << "the hold catches the tip";
  ASSERT_LT(breakaway_t + 1.5, 13.5) << "some of the hold is left to check";
}

// Switching the lateral axis from displacement to force control, and the
// normal axis from open to closed loop, starts the new loop from the present
// drive: no step in the drive beyond what the plant itself asks per tick.
TEST(Controller, ModeSwitchesAreBumpless) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const auto run = run_in_loop(config, parse_protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 4 } }
    segments { duration_s: 1 normal { end_uN: 2000 } lateral { shape: HOLD } }
    segments { duration_s: 1 normal { mode: NORMAL_CLOSED_LOOP_FORCE shape: HOLD }
               lateral { mode: LATERAL_FORCE shape: HOLD max_excursion_um: 1 } }
    segments { duration_s: 1 normal { shape: HOLD } lateral { shape: HOLD } }
  )"));
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted);
  for (const std::uint64_t at : {20000u, 30000u}) {  // the ticks where the modes change
    double typical = 0;
    for (std::uint64_t k = at - 200; k < at - 1; ++k) {
      typical = std::max(typical, std::fabs(run.drives[k + 1].lateral_force_n - run.drives[k].lateral_force_n));
    }
    const double lateral_step = std::fabs(run.drives[at].lateral_force_n - run.drives[at - 1].lateral_force_n);
    const double normal_step = std::fabs(run.drives[at].normal_force_n - run.drives[at - 1].normal_force_n);
    EXPECT_LT(lateral_step, 2 * typical + 1e-6) << "lateral drive steps at tick " << at;
    EXPECT_LT(normal_step, 1e-6) << "normal drive steps at tick " << at;
  }
}

// New gains through the loop's mailbox, mid-scratch: the drive continues
// without a step although the new kp alone would move it by mN.
TEST(Controller, GainChangeWhileRunningIsBumpless) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  PidGains stiffer = pid_gains_from_proto(config.controller().lateral_displacement());
  stiffer.kp = 3000;
  stiffer.ki = 20000;
  stiffer.setpoint_weight_p = 1;
  constexpr std::uint64_t kChange = 150000;  // t = 15 s, mid-scratch at +6 µm
  const auto run = run_in_loop(config, testing::load_protocol_file("standard_scratch.textproto"),
                               [&](std::uint64_t tick, RunControl& control) {
                                 if (tick == kChange) control.gain_updates.try_push({Loop::kLateralDisplacement, stiffer});
                               });
  ASSERT_EQ(run.outcome.end, RunEnd::kCompleted);
  double typical = 0;
  for (std::uint64_t k = kChange - 1000; k < kChange - 1; ++k) {
    typical = std::max(typical, std::fabs(run.drives[k + 1].lateral_force_n - run.drives[k].lateral_force_n));
  }
  const double step = std::fabs(run.drives[kChange].lateral_force_n - run.drives[kChange - 1].lateral_force_n);
  EXPECT_LT(step, 2 * typical + 1e-6) << "typical per-tick change " << typical;
  // And the new gains act: with b = 1 and the stiffer loop the ramp lag shrinks.
  const auto lag = [&](double from, double to) {
    return mean_between(run.samples, from, to, &Sample::lateral_setpoint_m) -
           mean_between(run.samples, from, to, &Sample::lateral_position_m);
  };
  EXPECT_LT(lag(20, 24), 0.3 * lag(12, 15));
}

// The set-point weight b: the I-PD loop lags a ramp by (k + kp)/ki x v; with
// b = 1 the proportional term acts on the error and the lag falls towards k/ki x v.
TEST(Controller, SetpointWeightOnPCutsTheRampLag) {
  v1::DaemonConfig config = tribo::testing::default_config();
  const v1::Protocol ramp = parse_protocol(R"(
    segments { duration_s: 4 normal { end_uN: 0 } lateral { end_um: 8 } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
  )");
  const auto lag = [&](const testing::LoopRun& r) {
    return mean_between(r.samples, 2, 4, &Sample::lateral_setpoint_m) -
           mean_between(r.samples, 2, 4, &Sample::lateral_position_m);
  };
  // The default's gains (Table 5.1: kp 420, ki 7116; Appendix C's were 1394, 7167).
  const double k = config.sim().lateral().spring_stiffness_n_per_m();
  const double kp = config.controller().lateral_displacement().kp(), ki = config.controller().lateral_displacement().ki();
  ASSERT_GT(kp, 0);
  const double ipd = lag(run_in_loop(config, ramp));
  config.mutable_controller()->mutable_lateral_displacement()->set_setpoint_weight_p(1);
  const double pid = lag(run_in_loop(config, ramp));
  const double v = 2e-6;
  EXPECT_NEAR(ipd, (k + kp) / ki * v, 0.02e-6);
  EXPECT_NEAR(pid, k / ki * v, 0.01e-6);
}

}  // namespace
}  // namespace tribo::daemon
