#include "daemon/pid.h"

#include <gtest/gtest.h>

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

TEST(Pid, DerivativeFilterSpreadsTheKick) {
  PidGains g = gains();
  g.setpoint_weight_d = 1;
  g.derivative_filter_hz = 10;
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  pid_update(g, 1.0, 0.0, 0, 0.001, s);
  EXPECT_GT(s.derivative, 0.0);
  EXPECT_LT(s.derivative, 0.5 * 1.0 / 0.001) << "less than the unfiltered kick";
}

TEST(Pid, ConditionalIntegrationHoldsTheIntegratorInSaturation) {
  PidGains g = gains();
  g.output_max = 1;
  PidState s;
  pid_reset(g, 0, 0, 0, 0, s);
  double u = 0;
  for (int i = 0; i < 1000; ++i) u = pid_update(g, 10.0, 0.0, 0, 0.01, s);
  EXPECT_DOUBLE_EQ(u, 1.0);
  EXPECT_TRUE(s.saturated);
  EXPECT_LE(s.integral, 1.0 + 10 * 0.01 * 10.0) << "the integrator did not wind up";
  // Once the error reverses, the output leaves saturation at once.
  u = pid_update(g, 0.0, 10.0, 0, 0.01, s);
  EXPECT_LT(u, 1.0);
}

TEST(Pid, ResetIsBumpless) {
  PidGains g = gains();
  PidState s;
  pid_reset(g, 2.0, 1.5, 0, 0.7, s);
  // Same setpoint and measurement right after the reset: output continues at
  // 0.7 plus one step of integration.
  EXPECT_NEAR(pid_update(g, 2.0, 1.5, 0, 0.001, s), 0.7 + 10 * 0.001 * 0.5, 1e-12);
}

}  // namespace
}  // namespace tribo::daemon
