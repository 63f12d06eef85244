#include "sim/lugre_friction.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sim/lateral_plant.h"
#include "sim/quarter_sine.h"
#include "sim/step_size.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

// The plant under test is declared: plain LuGre (tests/sim/sim_test_support.h),
// not the default instrument.
using testing::plain_lugre_config;

// Dissertation §2 (eqs. 9-13), written out here independently of sim/: the dissertation's
// modified LuGre in steady sliding, F = Fc + (Fs - Fc) exp(-|v|/vs) + s2 v.
double stribeck_formula_n(const v1::FrictionParams& f, double load_n, double v) {
  const double fs = f.static_coeff() * load_n;
  const double fc = f.coulomb_coeff() * load_n;
  return fc + (fs - fc) * std::exp(-std::fabs(v) / f.stribeck_velocity_m_per_s()) +
         f.viscous_n_s_per_m() * v;
}

// The closed loop drags the tip at constant velocity; once the bristles have
// settled, the plant's friction (true state) and the transducer's lateral
// force must both equal the Stribeck function at that velocity and load.
class SteadyStateFriction : public ::testing::TestWithParam<double> {};

TEST_P(SteadyStateFriction, EqualsTheStribeckFunction) {
  v1::DaemonConfig config = plain_lugre_config();
  testing::silence_sensors(config);
  const double v = GetParam();
  const double load = 2e-3;
  const double t_move = 1.5, travel = 6e-6, t_end = t_move + travel / v;
  double friction_sum = 0, force_sum = 0, load_sum = 0;
  int n = 0;
  testing::run_closed_loop(
      config, 1, t_end,
      [&](double t) {
        return testing::LoopSetpoints{t < 1 ? load * t : load,
                                      2e-6 + (t > t_move ? v * (t - t_move) : 0)};
      },
      [&](double t, const hal::SimTransducer& tr) {
        if (t < t_end - 0.25 * (t_end - t_move)) return;  // last quarter: settled
        friction_sum += tr.instrument().truth().friction_n;
        force_sum += tr.instrument().measurement().lateral_force_n;
        load_sum += tr.instrument().truth().normal.contact_load_n;
        ++n;
      });
  const double expected = stribeck_formula_n(config.sim().friction(), load_sum / n, v);
  EXPECT_NEAR(friction_sum / n, expected, 1e-3 * expected) << "v = " << v;
  // The transducer reports drive minus spring force, which adds c v, and the
  // tip tilt's lateral push N tan(theta) towards +x, which it subtracts.
  const double damping = config.sim().lateral().damping_n_s_per_m() * v;
  const double tilt = (load_sum / n) * std::tan(config.sim().tip().tilt_offset().angle_deg() * std::numbers::pi / 180);
  ASSERT_TRUE(config.sim().tip().tilt_offset().enabled());
  EXPECT_NEAR(force_sum / n, expected + damping - tilt, 1e-3 * expected) << "v = " << v;
}

INSTANTIATE_TEST_SUITE_P(Velocities, SteadyStateFriction,
                         ::testing::Values(0.5e-6, 1.2e-6, 4e-6, 18e-6));

TEST(LugreFriction, BristleSettlesOnItsSteadyDeflectionAtConstantVelocity) {
  const LugreParams p{3414.6, 5.54, 0.001, 0.1427, 0.0996, 1.2e-6, 1.0, 0.0};
  const FrictionLevels levels = friction_levels(p, 1e-3);
  const double v = 2e-6;
  double z = 0;
  // Relaxation rate v/g = 63 1/s: 1 s is 63 time constants.
  for (int i = 0; i < 400000; ++i) z += 2.5e-6 * lugre_evaluate(p, levels, v, z).dz_dt_m_per_s;
  const double g = stribeck_n(p, levels, v) / p.sigma0_n_per_m;
  EXPECT_NEAR(z, g, 1e-6 * g);
  EXPECT_NEAR(lugre_evaluate(p, levels, v, z).force_n, steady_state_friction_n(p, 1e-3, v), 1e-9);
}

TEST(LugreFriction, GaussianShapeUsesTheSquaredRatio) {
  LugreParams p{1000, 1, 0, 0.2, 0.1, 1e-6, 2.0, 0.0};
  const double v = 1.5e-6;
  EXPECT_DOUBLE_EQ(steady_state_friction_n(p, 1.0, v), 0.1 + 0.1 * std::exp(-1.5 * 1.5));
  EXPECT_DOUBLE_EQ(steady_state_friction_n(p, 1.0, -v), -(0.1 + 0.1 * std::exp(-1.5 * 1.5)));
}

TEST(LugreFriction, OutOfContactThereIsNoFriction) {
  const LugreParams p{3414.6, 5.54, 0.001, 0.1427, 0.0996, 1.2e-6, 1.0, 0.0};
  const auto out = lugre_evaluate(p, friction_levels(p, 0.0), 1e-5, 1e-8);
  EXPECT_EQ(out.force_n, 0.0);
  EXPECT_EQ(out.dz_dt_m_per_s, 0.0);
}

TEST(ElastoPlastic, UnloadingIsElasticAndSlidingIsUnchanged) {
  const LugreParams p{3414.6, 5.54, 0.001, 0.1427, 0.0996, 1.2e-6, 1.0, 0.8};
  const FrictionLevels levels = friction_levels(p, 1e-3);
  const double g = stribeck_n(p, levels, 1e-6) / p.sigma0_n_per_m;
  const double r = p.breakaway_ratio;
  EXPECT_EQ(plasticity(r, -1e-6, 0.9 * g, g), 0.0) << "moving against the deflection";
  EXPECT_EQ(plasticity(r, 1e-6, 0.5 * g, g), 0.0) << "below breakaway";
  EXPECT_EQ(plasticity(r, 1e-6, g, g), 1.0) << "fully sliding";
  const double mid = plasticity(r, 1e-6, 0.9 * g, g);
  EXPECT_GT(mid, 0.0);
  EXPECT_LT(mid, 1.0);
  EXPECT_DOUBLE_EQ(lugre_evaluate(p, levels, 1e-6, g).dz_dt_m_per_s, 0.0);
}

// The blend's sine (sim/quarter_sine.h, for speed) is sin to within
// 3 units in the last place over the whole quarter wave its argument spans,
// and the blend it gives is Dupont's sine blend to 1e-14 (the argument,
// scaled by pi / (1 - r) = 38, carries the rounding of z / g): the polynomial
// changes rounding, not the law. (Without its last term, x^21, the sine
// misses the first bound, by 4 units; without the last two by 394.)
TEST(ElastoPlastic, TheBlendsSineIsSinToTheLastBits) {
  for (int i = -200000; i <= 200000; ++i) {
    const double x = std::numbers::pi / 2 * i / 200000.0;
    const double exact = std::sin(x);
    const double ulp = std::nextafter(std::fabs(exact), 2.0) - std::fabs(exact);
    ASSERT_LE(std::fabs(sine_on_quarter(x) - exact), 3 * ulp) << "x = " << x;
  }
  const double r = 0.917056, g = 3e-8, v = 1e-6;
  for (int i = 1; i < 1000; ++i) {
    const double z = g * (r + (1 - r) * i / 1000.0);
    const double dupont = 0.5 + 0.5 * std::sin(std::numbers::pi * (z - 0.5 * (1 + r) * g) / ((1 - r) * g));
    EXPECT_NEAR(plasticity(r, v, z, g), dupont, 1e-14) << "z/g = " << z / g;
  }
}

// At light loads the bristle relaxes faster than any affordable step; the
// split scheme must land it on its steady deflection without blowing up, and
// agree with RK4 where RK4 can resolve the relaxation.
LateralPlant appendix_c_plant() {
  LateralPlant plant;
  plant.axis = LateralAxisParams{1e-3, 116, 0.008, {}};
  plant.friction.lugre = LugreParams{3414.6, 5.54, 0.001, 0.1427, 0.0996, 1.2e-6, 1.0, 0.0};
  return plant;
}

LateralInputs held(const LateralPlant& plant, double load_n, double drive_n) {
  LateralInputs in;
  in.drive = ideal_drive_field(drive_n);
  in.levels = friction_levels(plant.friction.lugre, load_n);
  return in;
}

TEST(Integrator, SplitSchemeAgreesWithRk4WhereBothResolveTheBristle) {
  const LateralPlant plant = appendix_c_plant();
  const LateralInputs in = held(plant, 1e-3, 5e-4);
  LateralState rk;
  rk.position_m = 2e-6;
  rk.velocity_m_per_s = 3e-6;
  LateralState split = rk;
  for (int i = 0; i < 1000; ++i) {
    integrate_lateral(plant, in, 1e-4, 50, rk);
    integrate_lateral_split(plant, in, 1e-4, 50, split);
  }
  EXPECT_NEAR(split.position_m, rk.position_m, 1e-3 * std::fabs(rk.position_m));
  EXPECT_NEAR(split.bristle_m, rk.bristle_m, 1e-3 * std::fabs(rk.bristle_m) + 1e-12);
}

TEST(Integrator, LightLoadUsesTheSplitSchemeAndStaysFinite) {
  const LateralPlant plant = appendix_c_plant();
  const LugreParams& p = plant.friction.lugre;
  const LateralInputs in = held(plant, 3e-10, 2e-4);  // first tick of a loading ramp
  LateralState s;
  s.position_m = 2e-6;
  s.velocity_m_per_s = 4e-7;
  const LateralRates rates = lateral_rate_bounds(plant, in, s, lateral_derivative(plant, in, s), 1e-4);
  const StepPlan plan = plan_substeps(rates, 1e-4, 1.0, 1000);
  EXPECT_TRUE(plan.split);
  EXPECT_FALSE(plan.capped);
  integrate_lateral_split(plant, in, 1e-4, plan.substeps, s);
  const double g = stribeck_n(p, in.levels, s.velocity_m_per_s) / p.sigma0_n_per_m;
  EXPECT_TRUE(std::isfinite(s.position_m) && std::isfinite(s.velocity_m_per_s));
  const double z_ss = s.velocity_m_per_s > 0 ? g : -g;
  EXPECT_NEAR(s.bristle_m, z_ss, 1e-6 * g) << "relaxed onto its steady deflection";
}

}  // namespace
}  // namespace tribo::sim
