#include "daemon/pid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
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

// pid_update written out without the controller's kept terms: every division
// made every call.
double reference_update(const PidGains& g, double r, double y, double f, double dt, PidState& s) {
  const double error = r - y;
  const double p = g.kp * (g.setpoint_weight_p * r - y);
  const double d_input = g.setpoint_weight_d * r - y;
  const double tf = g.derivative_filter_hz > 0 ? 1.0 / (2.0 * std::numbers::pi * g.derivative_filter_hz) : 0.0;
  s.derivative = (tf * s.derivative + g.kd * (d_input - s.previous_d_input)) / (tf + dt);
  s.previous_d_input = d_input;
  const double candidate = s.integral + g.ki * dt * error;
  const double unclamped = p + candidate + s.derivative + g.feedforward_gain * f;
  const double output = std::clamp(unclamped, g.output_min, g.output_max);
  if (g.anti_windup == AntiWindup::kConditionalIntegration) {
    if (!((unclamped > g.output_max && error > 0) || (unclamped < g.output_min && error < 0))) s.integral = candidate;
  } else if (g.anti_windup == AntiWindup::kBackCalculation) {
    s.integral = candidate + std::min(1.0, dt / pid_tracking_time_s(g, dt)) * (output - unclamped);
  } else {
    s.integral = candidate;
  }
  s.output = output;
  return output;
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// The controller's path (pid_terms once, then pid_update with them, which
// skips the derivative's division when its numerator is zero) gives the
// reference's outputs and states bit for bit: with and without D and its
// filter, each anti-windup, through saturation, and from a derivative of -0
// (left by a gain change to kd = 0 while D was negative), whose sign a
// skipped division must keep.
TEST(Pid, KeptTermsGiveTheBitsOfEveryDivisionMadeEveryCall) {
  int steps = 0;
  for (double kd : {0.0, 0.5}) {
    for (double filter_hz : {0.0, 1000.0}) {
      for (AntiWindup aw : {AntiWindup::kNone, AntiWindup::kConditionalIntegration, AntiWindup::kBackCalculation}) {
        PidGains g = gains();
        g.kd = kd;
        g.derivative_filter_hz = filter_hz;
        g.anti_windup = aw;
        g.feedforward_gain = 1;
        g.output_min = -3;
        g.output_max = 3;
        const double dt = 1e-4;
        PidState fast, slow;
        pid_reset(g, 0, 0, 0, 0, fast);
        pid_reset(g, 0, 0, 0, 0, slow);
        if (kd == 0) {
          fast.derivative = slow.derivative = -0.0;
          fast.previous_d_input = slow.previous_d_input = 0.25;  // 0 kd (y' - 0.25) = -0 for y' > 0.25
        }
        const PidTerms terms = pid_terms(g, dt);
        for (int i = 0; i < 400; ++i) {
          const double r = 1e-6 * i, y = r - 0.3 * std::sin(0.05 * i) - (i < 200 ? 0.0 : 0.26), f = 0.01 * i;
          const double a = pid_update(g, terms, r, y, f, dt, fast);
          const double b = reference_update(g, r, y, f, dt, slow);
          ASSERT_EQ(bits(a), bits(b)) << "step " << i;
          ASSERT_EQ(bits(fast.derivative), bits(slow.derivative)) << "step " << i;
          ASSERT_EQ(bits(fast.integral), bits(slow.integral)) << "step " << i;
          ++steps;
        }
      }
    }
  }
  EXPECT_EQ(steps, 12 * 400);
}

}  // namespace
}  // namespace tribo::daemon
