#include "daemon/pid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace tribo::daemon {
namespace {

PidGains gains() {
  PidGains g;
  g.kp = 2;
  g.ki = 10;
  g.kd = 0.5;
  g.output_min = -100;
  g.output_max = 100;
  return g;
}

TEST(Pid, IpdActsOnTheMeasurementOnlyInPAndD) {
  PidGains g = gains();  // b = c = 0
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  // A setpoint step with the measurement at rest: no P or D kick, only I.
  const double u = pid_update(g, 1.0, 0.0, 0, 0.01, s);
  EXPECT_DOUBLE_EQ(u, 10 * 0.01 * 1.0);
}

TEST(Pid, SetpointWeightsOneGiveTheTextbookPid) {
  PidGains g = gains();
  g.setpoint_weight_p = 1;
  g.setpoint_weight_d = 1;
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  const double u = pid_update(g, 1.0, 0.0, 0, 0.01, s);
  // P = 2, I = 0.1, unfiltered D = kd * (1 - 0) / dt = 50
  EXPECT_DOUBLE_EQ(u, 2 + 0.1 + 50);
}

TEST(Pid, DerivativeFilterIsAFirstOrderLowPassOfTheKick) {
  PidGains g = gains();
  g.ki = 0;
  g.kp = 0;
  g.setpoint_weight_d = 1;
  g.derivative_filter_hz = 10;
  const double dt = 0.001, tf = 1 / (2 * std::numbers::pi * 10);
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  const double first = pid_update(g, 1.0, 0.0, 0, dt, s);
  EXPECT_NEAR(first, 0.5 * 1.0 / (tf + dt), 1e-12) << "kd * step / (Tf + dt)";
  // Then it decays by Tf / (Tf + dt) per step.
  const double second = pid_update(g, 1.0, 0.0, 0, dt, s);
  EXPECT_NEAR(second / first, tf / (tf + dt), 1e-12);
}

// With the plant frozen (constant error e > 0) and the output saturated, the
// three anti-windup schemes keep the integrator exactly as their definitions
// in daemon/pid.h say.
struct Saturated {
  PidState s;
  double integral_before = 0;
  double integral_after = 0;
};

Saturated saturate(AntiWindup scheme, int steps) {
  PidGains g = gains();
  g.kd = 0;
  g.output_max = 1;
  g.anti_windup = scheme;
  g.tracking_time_s = 0.05;
  Saturated r;
  pid_reset(g, 0, 0, 0, 0, r.s);
  for (int i = 0; i < steps; ++i) pid_update(g, 10.0, 0.0, 0, 0.01, r.s);
  r.integral_before = r.s.integral;
  pid_update(g, 10.0, 0.0, 0, 0.01, r.s);
  r.integral_after = r.s.integral;
  return r;
}

TEST(Pid, WithoutAntiWindupTheIntegratorGrowsThroughSaturation) {
  const Saturated r = saturate(AntiWindup::kNone, 1000);
  EXPECT_TRUE(r.s.saturated);
  EXPECT_DOUBLE_EQ(r.s.output, 1.0);
  EXPECT_NEAR(r.integral_after - r.integral_before, 10 * 0.01 * 10.0, 1e-9) << "ki dt e every step";
  EXPECT_GT(r.integral_after, 900);
}

TEST(Pid, ConditionalIntegrationHoldsTheIntegratorWhileSaturatedAndPushing) {
  const Saturated r = saturate(AntiWindup::kConditionalIntegration, 1000);
  EXPECT_TRUE(r.s.saturated);
  EXPECT_EQ(r.integral_after, r.integral_before);
  EXPECT_LT(r.integral_after, 2.0);
}

TEST(Pid, BackCalculationSettlesWhereTrackingBalancesIntegration) {
  // Fixed point of I += ki dt e + (dt/Tt)(u - v): v - u = ki e Tt = 10 * 10 * 0.05 = 5.
  const Saturated r = saturate(AntiWindup::kBackCalculation, 2000);
  EXPECT_TRUE(r.s.saturated);
  // v = P + I + ki dt e with P = 0 (b = 0, y = 0); u = 1.
  const double v = r.integral_after + 10 * 0.01 * 10.0;
  EXPECT_NEAR(v - 1.0, 10 * 10.0 * 0.05, 1e-6);
  EXPECT_NEAR(r.integral_after, r.integral_before, 1e-9);
}

TEST(Pid, DefaultTrackingTimeIsTheGeometricMeanOfTiAndTd) {
  PidGains g = gains();  // Ti = 0.2 s, Td = 0.25 s
  EXPECT_DOUBLE_EQ(pid_tracking_time_s(g, 1e-4), std::sqrt(0.2 * 0.25));
  g.kd = 0;
  EXPECT_DOUBLE_EQ(pid_tracking_time_s(g, 1e-4), 0.2);
  g.tracking_time_s = 0.7;
  EXPECT_DOUBLE_EQ(pid_tracking_time_s(g, 1e-4), 0.7);
}

// On a plant dy/dt = u with the output limited to [-1, 1], a large setpoint
// step saturates the loop for a long time. Without anti-windup the
// integrator overshoots far; the two schemes keep the overshoot small.
double overshoot(AntiWindup scheme) {
  PidGains g;
  g.kp = 2;
  g.ki = 1;
  g.setpoint_weight_p = 1;
  g.output_min = -1;
  g.output_max = 1;
  g.anti_windup = scheme;
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  double y = 0, peak = 0;
  const double dt = 0.01;
  for (int i = 0; i < 6000; ++i) {
    const double u = pid_update(g, 10.0, y, 0, dt, s);
    y += u * dt;
    peak = std::max(peak, y);
  }
  EXPECT_NEAR(y, 10.0, 0.05) << "settles in any case";
  return peak - 10.0;
}

TEST(Pid, AntiWindupLimitsTheOvershootAfterSaturation) {
  const double none = overshoot(AntiWindup::kNone);
  const double conditional = overshoot(AntiWindup::kConditionalIntegration);
  const double back = overshoot(AntiWindup::kBackCalculation);
  EXPECT_GT(none, 5.0);
  EXPECT_LT(conditional, 0.5);
  EXPECT_LT(back, 0.5);
}

TEST(Pid, FeedForwardActsAtOnceWithItsGain) {
  PidGains g = gains();
  g.feedforward_gain = 0.5;
  PidState s;
  pid_reset(g, 1, 1, 0, 0, s);
  const double base = pid_update(g, 1, 1, 0, 0.01, s);
  const double with_ff = pid_update(g, 1, 1, 4, 0.01, s);
  EXPECT_DOUBLE_EQ(with_ff - base, 0.5 * 4);
}

TEST(Pid, ResetIsBumpless) {
  PidGains g = gains();
  g.feedforward_gain = 1;
  PidState s;
  pid_reset(g, 2.0, 1.5, 0.3, 0.7, s);
  // Same inputs right after the reset: the output continues at 0.7 plus one
  // step of integration.
  EXPECT_NEAR(pid_update(g, 2.0, 1.5, 0.3, 0.001, s), 0.7 + 10 * 0.001 * 0.5, 1e-12);
  // Reset to zero is the classic reset.
  pid_reset(g, 2.0, 2.0, 0.0, 0.0, s);
  EXPECT_DOUBLE_EQ(pid_update(g, 2.0, 2.0, 0.0, 0.001, s), 0.0);
}

TEST(Pid, GainChangeIsBumplessAndTheNewGainsActNext) {
  PidGains g = gains();
  g.derivative_filter_hz = 100;
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  double y = 0;
  for (int i = 0; i < 50; ++i) {
    pid_update(g, 1.0, y, 0, 0.001, s);
    y += 0.01;
  }
  const double before = s.output;
  PidGains stiffer = g;
  stiffer.kp = 20;
  stiffer.kd = 2;
  stiffer.ki = 30;
  pid_change_gains(g, stiffer, s);
  EXPECT_DOUBLE_EQ(s.output, before);
  // With the same inputs as the last step, only the filtered derivative decays and the integrator steps.
  PidState twin = s;
  const double next = pid_update(stiffer, 1.0, y - 0.01, 0, 0.001, s);
  EXPECT_NEAR(next, before + 30 * 0.001 * (1.0 - (y - 0.01)) +
                        (twin.derivative * (1 / (2 * std::numbers::pi * 100)) /
                             (1 / (2 * std::numbers::pi * 100) + 0.001) -
                         twin.derivative),
              1e-9);
  // A change of measurement now moves the output by the new kp (b = 0).
  PidState a = s, b = s;
  const double u0 = pid_update(stiffer, 1.0, y, 0, 0.001, a);
  const double u1 = pid_update(stiffer, 1.0, y + 1e-3, 0, 0.001, b);
  const double tf = 1 / (2 * std::numbers::pi * 100);
  EXPECT_NEAR(u0 - u1, 20 * 1e-3 + 30 * 0.001 * 1e-3 + 2 * 1e-3 / (tf + 0.001), 1e-9);
}

TEST(Pid, InvalidInputHoldsTheOutputAndLeavesTheStateAlone) {
  PidGains g = gains();
  PidState s, twin;
  pid_reset(g, 0, 0, 0, 0, s);
  pid_reset(g, 0, 0, 0, 0, twin);
  pid_update(g, 1.0, 0.2, 0, 0.01, s);
  pid_update(g, 1.0, 0.2, 0, 0.01, twin);
  const double held = s.output;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(pid_update(g, 1.0, nan, 0, 0.01, s), held);
  EXPECT_TRUE(s.input_invalid);
  EXPECT_EQ(pid_update(g, nan, 0.2, 0, 0.01, s), held);
  EXPECT_EQ(pid_update(g, 1.0, 0.2, std::numeric_limits<double>::infinity(), 0.01, s), held);
  EXPECT_EQ(pid_update(g, 1.0, 0.2, 0, 0.0, s), held);
  EXPECT_EQ(pid_update(g, 1.0, 0.2, 0, -0.01, s), held);
  EXPECT_EQ(pid_update(g, 1.0, 0.2, 0, nan, s), held);
  // Then it continues exactly as if those calls had not happened.
  EXPECT_EQ(pid_update(g, 1.0, 0.25, 0, 0.01, s), pid_update(g, 1.0, 0.25, 0, 0.01, twin));
  EXPECT_FALSE(s.input_invalid);
}

}  // namespace
}  // namespace tribo::daemon
