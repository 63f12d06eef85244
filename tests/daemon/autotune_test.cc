// Relay autotune of the lateral loop on the simulated instrument.
#include "daemon/autotune.h"

#include <gtest/gtest.h>

#include <numbers>

#include "daemon/controller.h"
#include "hal/backend_factory.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

AutotuneParams params_from(const v1::DaemonConfig& c) {
  AutotuneParams p;
  p.relay_amplitude_n = c.autotune().relay_amplitude_n();
  p.hysteresis_m = c.autotune().hysteresis_m();
  p.position_m = c.autotune().position_m();
  p.cycles = c.autotune().cycles();
  p.max_duration_s = c.autotune().max_duration_s();
  p.max_travel_m = c.limits().max_lateral_travel_m();
  p.present = pid_gains_from_proto(c.controller().lateral_displacement());
  return p;
}

struct LimitCycle {
  double period_s = 0;
  double amplitude_m = 0;
};

// The same relay, sampled at the loop period, on the linear plant m x'' +
// c x' + k x = u (the unloaded lateral axis of the config), integrated
// finely; started at rest at x0, measured over cycles 300-400. A lightly
// damped plant sampled by a relay admits several limit cycles (periods a few
// ticks apart) depending on where it starts: x0 picks one.
LimitCycle linear_relay(const v1::DaemonConfig& config, double x0) {
  const auto& l = config.sim().lateral();
  const double m = l.moving_mass_kg(), k = l.spring_stiffness_n_per_m(), c = l.damping_n_s_per_m();
  const double dt = 1.0 / config.controller().loop_rate_hz(), r = config.autotune().position_m();
  const double d = config.autotune().relay_amplitude_n(), eps = config.autotune().hysteresis_m();
  const double bias = k * r;
  double x = x0, v = 0, u = bias + d, lo = x, hi = x;
  std::vector<double> switches, amplitudes;
  const int sub = 20;
  const double h = dt / sub;
  for (int n = 0; switches.size() < 401; ++n) {
    const double e = r - x;
    if (e > eps && u < bias) {
      u = bias + d;
      switches.push_back(n * dt);
      if (switches.size() > 1) amplitudes.push_back(0.5 * (hi - lo));
      lo = hi = x;
    } else if (e < -eps && u > bias) {
      u = bias - d;
    }
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    for (int s = 0; s < sub; ++s) {  // RK4
      const auto f = [&](double xx, double vv) { return std::pair{vv, (u - k * xx - c * vv) / m}; };
      const auto [k1x, k1v] = f(x, v);
      const auto [k2x, k2v] = f(x + h / 2 * k1x, v + h / 2 * k1v);
      const auto [k3x, k3v] = f(x + h / 2 * k2x, v + h / 2 * k2v);
      const auto [k4x, k4v] = f(x + h * k3x, v + h * k3v);
      x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
      v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
  }
  LimitCycle out;
  out.period_s = (switches[400] - switches[300]) / 100;
  for (int i = 299; i < 399; ++i) out.amplitude_m += amplitudes[i] / 100;
  return out;
}

TEST(Autotune, MeasuresTheUltimateGainAndPeriodOfTheLateralAxis) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  auto transducer = hal::make_transducer(config, 1);
  const AutotuneParams p = params_from(config);
  const AutotuneResult r = relay_autotune(*transducer, p);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.cycles, 10u);
  EXPECT_GT(r.settling_cycles, 10u) << "the resonant plant needs tens of cycles to settle";

  // The limit cycles the linear plant admits, from rest at the relay
  // position and from rest two micrometres away; the measurement lies in
  // their band.
  const LimitCycle near = linear_relay(config, p.position_m), far = linear_relay(config, 0);
  const auto ku = [&](const LimitCycle& c) {
    return 4 * p.relay_amplitude_n / (std::numbers::pi * std::sqrt(c.amplitude_m * c.amplitude_m - p.hysteresis_m * p.hysteresis_m));
  };
  EXPECT_GE(r.ultimate_period_s, 0.99 * std::min(near.period_s, far.period_s));
  EXPECT_LE(r.ultimate_period_s, 1.01 * std::max(near.period_s, far.period_s));
  EXPECT_GE(r.ultimate_gain_n_per_m, 0.98 * std::min(ku(near), ku(far)));
  EXPECT_LE(r.ultimate_gain_n_per_m, 1.02 * std::max(ku(near), ku(far)));
  // Both above the 54 Hz resonance of 1 g on 116 N/m: the plant turns -180
  // degrees only there.
  EXPECT_LT(r.ultimate_period_s, 2 * std::numbers::pi / std::sqrt(116 / 1e-3));

  // Ziegler-Nichols from Ku and Pu, the present loop's structure kept.
  EXPECT_DOUBLE_EQ(r.proposed.kp, 0.6 * r.ultimate_gain_n_per_m);
  EXPECT_DOUBLE_EQ(r.proposed.ki, r.proposed.kp / (r.ultimate_period_s / 2));
  EXPECT_DOUBLE_EQ(r.proposed.kd, r.proposed.kp * r.ultimate_period_s / 8);
  EXPECT_EQ(r.proposed.setpoint_weight_p, p.present.setpoint_weight_p);
  EXPECT_EQ(r.proposed.derivative_filter_hz, p.present.derivative_filter_hz);
  EXPECT_EQ(r.proposed.output_max, p.present.output_max);

  // The axis is back where it started.
  hal::SensorFrame f;
  transducer->read(f);
  EXPECT_NEAR(f.lateral_position_m, 0, 0.05e-6);

  // Reproducible from the seed.
  auto again = hal::make_transducer(config, 1);
  EXPECT_EQ(relay_autotune(*again, p).ultimate_gain_n_per_m, r.ultimate_gain_n_per_m);
}

TEST(Autotune, ARelayTooStrongForTheTravelIsStopped) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  auto transducer = hal::make_transducer(config, 1);
  AutotuneParams p = params_from(config);
  p.relay_amplitude_n = 2e-3;  // a limit cycle of ~20 µm
  const AutotuneResult r = relay_autotune(*transducer, p);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("left the travel"), std::string::npos) << r.error;
}

TEST(Autotune, TheServiceProposesAndOnRequestAppliesTheGains) {
  testing::ServiceFixture f;
  f.start();
  v1::Autotune request;
  v1::AutotuneReply reply;
  const auto failed = f.service->autotune(request, reply);
  ASSERT_FALSE(failed) << failed->message();
  EXPECT_GT(reply.ultimate_gain_n_per_m(), 0);
  EXPECT_FALSE(reply.applied());
  EXPECT_EQ(f.service->gains().loops(0).gains().kp(), f.config.controller().lateral_displacement().kp());
  request.set_apply(true);
  ASSERT_FALSE(f.service->autotune(request, reply));
  EXPECT_TRUE(reply.applied());
  EXPECT_EQ(f.service->gains().loops(0).gains().kp(), reply.proposed().kp());
  // Not while faulted.
  v1::EmergencyStopReply stopped;
  f.service->emergency_stop("", stopped);
  const auto error = f.service->autotune(request, reply);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::WRONG_STATE);
}

}  // namespace
}  // namespace tribo::daemon
