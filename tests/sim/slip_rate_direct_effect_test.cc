// The rate-and-state direct effect on the slip rate
// (sim.friction.rate_state.direct_effect_rate = RATE_STATE_DIRECT_SLIP_RATE;
// sim/friction_effects.h, stribeck_n_at_deflection) against the default,
// which takes the tip's velocity: a stuck contact takes no direct effect, a
// sliding one the same as the default, the implicit loop S <-> v_s is solved
// where plain fixed-point iteration would not converge, and the slip onset of
// a loaded contact no longer rises with the loading rate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "sim/friction_effects.h"
#include "sim/instrument_params.h"
#include "sim/lateral_plant.h"
#include "sim/step_size.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

constexpr double kLoadN = 9810e-6;  // Table 5.1's larger load

// The default instrument's contact (config/tribod.textproto), with the
// direct effect on the rate asked for.
FrictionModel contact(DirectEffectRate rate) {
  FrictionModel m = instrument_params_from_config(testing::default_config().sim()).friction;
  m.rate_state.direct_rate = rate;
  return m;
}

// The rate-and-state state at its value for a contact at rest (ageing law:
// d phi/dt = 0 at v_s = 0; the slip law does not move it there either).
double rest_state(const FrictionModel& m) {
  return m.rate_state.memory_length_m / m.rate_state.reference_velocity_m_per_s;
}

ContactPoint point(const FrictionModel& m, double v) { return ContactPoint{v, v, 0.0, 0.0, rest_state(m)}; }

TEST(SlipRateDirectEffect, TheDefaultRateIsUnchanged) {
  const FrictionModel m = contact(DirectEffectRate::kTipVelocity);
  const FrictionLevels levels = contact_levels(m, kLoadN, 0, 1);
  for (double v : {0.0, 2e-6, -9e-6, 36e-6}) {
    ContactPoint c = point(m, v);
    EXPECT_EQ(stribeck_n_at_deflection(m, levels, c, 0.1e-6), stribeck_n(m, levels, c)) << v;
  }
}

// Stuck (|z| <= r g: alpha = 0, no slip) the direct effect is absent with the
// slip rate, while the default adds a N ln(1 + |v| / V*) at the loading rate v.
TEST(SlipRateDirectEffect, AStuckContactTakesNoDirectEffect) {
  const FrictionModel slip = contact(DirectEffectRate::kSlipRate), tip = contact(DirectEffectRate::kTipVelocity);
  const FrictionLevels levels = contact_levels(slip, kLoadN, 0, 1);
  const double v = 8e-6;
  ContactPoint c = point(slip, v);
  const double s_rest = static_friction_n(slip, levels, c, v);
  const double z = 0.5 * slip.lugre.breakaway_ratio * s_rest / slip.lugre.sigma0_n_per_m;
  const double s_slip = stribeck_n_at_deflection(slip, levels, c, z);
  EXPECT_EQ(c.slip_rate_m_per_s, 0.0);
  EXPECT_NEAR(s_slip, s_rest, 1e-12 * s_rest);
  ContactPoint d = point(tip, v);
  const double s_tip = stribeck_n_at_deflection(tip, levels, d, z);
  const double direct_n = levels.rate_state_n * tip.rate_state.direct_coeff *
                          std::log1p(v / tip.rate_state.reference_velocity_m_per_s);
  EXPECT_GT(direct_n, 0.01 * s_rest);  // the comparison is not vacuous: 3 % of S here
  EXPECT_NEAR(s_tip - s_slip, direct_n, 1e-9 * s_rest);
}

// Sliding steadily (z = g, alpha = 1) the bristle is still: v_s = v, and S
// is the default's.
TEST(SlipRateDirectEffect, SteadySlidingTakesTheTipVelocity) {
  const FrictionModel slip = contact(DirectEffectRate::kSlipRate), tip = contact(DirectEffectRate::kTipVelocity);
  const FrictionLevels levels = contact_levels(slip, kLoadN, 0, 1);
  for (double v : {0.2e-6, 4e-6, -18e-6, 36e-6}) {
    ContactPoint d = point(tip, v);
    const double s_tip = stribeck_n(tip, levels, d);
    const double z = (v > 0 ? s_tip : -s_tip) / tip.lugre.sigma0_n_per_m;
    ContactPoint c = point(slip, v);
    const double s_slip = stribeck_n_at_deflection(slip, levels, c, z);
    EXPECT_NEAR(s_slip, s_tip, 1e-9 * s_tip) << v;
    EXPECT_NEAR(c.slip_rate_m_per_s, v, 1e-6 * std::fabs(v)) << v;
  }
}

// In the elasto-plastic blend (r g < |z| < g) S = F(S) = S at the slip rate
// alpha(z, S / sigma0) |v| z sigma0 / S. Where |F'| > 1 (a loading rate of a
// few V*, z near the middle of the blend) plain iteration S <- F(S) moves
// away from the root; the solver's S must still satisfy S = F(S), and the
// slip rate it reports must be the one at its S.
TEST(SlipRateDirectEffect, TheImplicitLoopIsSolvedInTheBlend) {
  FrictionModel m = contact(DirectEffectRate::kSlipRate);
  const FrictionLevels levels = contact_levels(m, kLoadN, 0, 1);
  const double sigma0 = m.lugre.sigma0_n_per_m, r = m.lugre.breakaway_ratio;
  auto f = [&](ContactPoint c, double z, double s) {
    const double g = s / sigma0;
    c.slip_rate_m_per_s = plasticity(r, c.velocity_m_per_s, z, g) * std::fabs(c.velocity_m_per_s) * z / g;
    return stribeck_n(m, levels, c);
  };
  int steep = 0;
  for (double v : {1e-6, 4e-6, 36e-6}) {
    for (double place : {0.05, 0.3, 0.5, 0.7, 0.95}) {  // where in the blend, at S at rest
      ContactPoint c = point(m, v);
      const double s_rest = static_friction_n(m, levels, c, v);
      const double z = (r + place * (1 - r)) * s_rest / sigma0;
      const double s = stribeck_n_at_deflection(m, levels, c, z);
      EXPECT_NEAR(s, f(c, z, s), 1e-9 * s) << v << " " << place;
      const double g = s / sigma0;
      EXPECT_NEAR(c.slip_rate_m_per_s, plasticity(r, v, z, g) * v * z / g, 1e-9 * v) << v << " " << place;
      const double ds = 1e-6 * s;
      steep += std::fabs((f(c, z, s + ds) - f(c, z, s - ds)) / (2 * ds)) > 1.0;
    }
  }
  EXPECT_GT(steep, 0) << "no case where plain iteration would diverge: the test does not test the solver";
}

// A contact at rest loaded by the tip at a constant velocity v (kinematic:
// only the bristle moves, dz/dt = v while stuck). The elastic force sigma0 z
// at which it starts to slip (alpha > 0 first): r S at rest with the slip
// rate, whatever v; r (S at rest + a N ln(1 + v / V*)) with the tip's
// velocity.
double slip_onset_force_n(const FrictionModel& m, double v) {
  LateralPlant plant;
  plant.axis = instrument_params_from_config(testing::default_config().sim()).lateral;
  plant.friction = m;
  LateralInputs in;
  in.drive = ideal_drive_field(0);
  in.levels = contact_levels(m, kLoadN, 0, 1);
  LateralState s;
  s.velocity_m_per_s = v;
  s.rate_state_s = rest_state(m);
  const double h = 1e-11 / v;  // the bristle moves 10 pm a step: 4e-5 of the onset deflection
  for (long i = 0; i < 100000000; ++i) {
    const LateralEvaluation e = lateral_derivative(plant, in, s);
    if (e.plasticity > 0) return m.lugre.sigma0_n_per_m * s.bristle_m;
    s.bristle_m += h * e.rate.bristle_m;  // exact while alpha = 0: dz/dt = v
  }
  return NAN;
}

TEST(SlipRateDirectEffect, TheSlipOnsetDoesNotRiseWithTheLoadingRate) {
  const FrictionModel slip = contact(DirectEffectRate::kSlipRate), tip = contact(DirectEffectRate::kTipVelocity);
  const FrictionLevels levels = contact_levels(slip, kLoadN, 0, 1);
  const double r = slip.lugre.breakaway_ratio, v_star = slip.rate_state.reference_velocity_m_per_s;
  ContactPoint c = point(slip, 0);
  const double held_n = r * static_friction_n(slip, levels, c, 1);
  const double tolerance_n = 1e-4 * held_n;  // the step: 4e-5 of the onset deflection
  const double slow = 4e-6, fast = 36e-6;
  const double slip_slow = slip_onset_force_n(slip, slow), slip_fast = slip_onset_force_n(slip, fast);
  const double tip_slow = slip_onset_force_n(tip, slow), tip_fast = slip_onset_force_n(tip, fast);
  std::printf("  slip onset at 4 / 36 um/s: slip rate %.1f / %.1f uN, tip velocity %.1f / %.1f uN\n",
              1e6 * slip_slow, 1e6 * slip_fast, 1e6 * tip_slow, 1e6 * tip_fast);
  EXPECT_NEAR(slip_slow, held_n, tolerance_n);
  EXPECT_NEAR(slip_fast, held_n, tolerance_n);
  const double a_n = levels.rate_state_n * tip.rate_state.direct_coeff;
  EXPECT_NEAR(tip_slow, held_n + r * a_n * std::log1p(slow / v_star), tolerance_n);
  EXPECT_NEAR(tip_fast, held_n + r * a_n * std::log1p(fast / v_star), tolerance_n);
  EXPECT_GT(tip_fast - tip_slow, 100 * tolerance_n);  // the default's rise is resolved
}

// Near zero load (the zero-load protocol: a few nN of contact force, g of
// order 1e-13 m) the bristle relaxes in nanoseconds and the split scheme
// lands it on its steady deflection in one tick: z = g at the slip rate v,
// dz/dt = 0, the force S (and sigma2 v). Held at g of its present (lower) slip rate it sat in
// the elasto-plastic blend with dz/dt ~ v, adding sigma1 v (2 uN at
// 0.4 um/s) to an S of a few nN.
TEST(SlipRateDirectEffect, TheSplitSchemeLandsALightContactOnSteadySliding) {
  LateralPlant plant;
  plant.axis = LateralAxisParams{1e-3, 116, 0.008, {}};
  plant.friction = contact(DirectEffectRate::kSlipRate);
  const LugreParams& p = plant.friction.lugre;
  LateralInputs in;
  in.drive = ideal_drive_field(2e-4);
  in.levels = contact_levels(plant.friction, 20e-9, 0, 1);
  LateralState s;
  // 0.1 uN of net pull: the plate speeds up by 0.1 um/s a tick, as under the
  // position loop, and the steady g rises with it.
  s.position_m = (2e-4 - 1e-7) / plant.axis.spring_n_per_m;
  s.velocity_m_per_s = 4e-7;
  s.rate_state_s = plant.friction.rate_state.memory_length_m / s.velocity_m_per_s;  // sliding's state
  const double dt_s = 1e-3;
  for (int tick = 0; tick < 5; ++tick) {
    const StepPlan plan = plan_substeps(lateral_rate_bounds(plant, in, s, lateral_derivative(plant, in, s), dt_s),
                                        dt_s, 1.5, 1000);
    ASSERT_TRUE(plan.split);
    integrate_lateral_split(plant, in, dt_s, plan.substeps, s);
    const LateralEvaluation e = lateral_derivative(plant, in, s);
    const double v = s.velocity_m_per_s;
    ContactPoint c{v, v, s.position_m, 0.0, s.rate_state_s};
    c.slip_rate_m_per_s = v;
    const double steady_n = stribeck_n(plant.friction, in.levels, c);
    ASSERT_GT(v, 0.0);
    EXPECT_LT(steady_n, 5e-9);  // the light contact this is about
    EXPECT_NEAR(s.bristle_m, steady_n / p.sigma0_n_per_m, 1e-3 * steady_n / p.sigma0_n_per_m) << tick;
    EXPECT_LT(std::fabs(e.rate.bristle_m), 1e-3 * v) << tick;
    // F = sigma0 z + sigma1 dz/dt + sigma2 v: S and the viscous term.
    EXPECT_NEAR(e.friction_n, steady_n + p.sigma2_n_s_per_m * v, 0.05 * steady_n) << tick;
  }
}

// The slip rate is solved for one bristle: with Maxwell-slip elements the
// config is refused, naming the field.
TEST(SlipRateDirectEffect, IsRefusedWithMaxwellSlipElements) {
  v1::DaemonConfig config = testing::default_config();
  auto* f = config.mutable_sim()->mutable_friction();
  f->mutable_rate_state()->set_direct_effect_rate(v1::RATE_STATE_DIRECT_SLIP_RATE);
  EXPECT_FALSE(validate_sim_config(config.sim()).has_value());
  f->mutable_presliding_hysteresis()->set_enabled(true);
  f->mutable_presliding_hysteresis()->set_elements(4);
  f->mutable_presliding_hysteresis()->set_spread(0.5);
  f->mutable_presliding_hysteresis()->set_breakaway_ratio(0.9);
  const auto error = validate_sim_config(config.sim());
  ASSERT_TRUE(error.has_value());
  EXPECT_NE(error->find("sim.friction.rate_state.direct_effect_rate"), std::string::npos) << *error;
}

}  // namespace
}  // namespace tribo::sim
