// The held-contact scheme (sim/held_contact.h) on its own: its order of
// convergence on a smooth case, against the law evaluated at every RK4 stage
// at a far finer step, and how many times it evaluates the contact law.
#include "sim/held_contact.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "daemon/daemon_config.h"
#include "sim/instrument_params.h"

namespace tribo::sim {
namespace {

InstrumentParams fitted() {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/config/instruments/dissertation_fit.textproto";
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  return instrument_params_from_config(config.sim());
}

struct SmoothCase {
  LateralPlant plant;
  LateralInputs in;
  LateralState start;
};

// The fitted contact (rate-and-state under the slip law, dwell) with a plain
// LuGre bristle (no elasto-plastic blend, whose switch is not smooth),
// sliding at 20 um/s under a held drive force below its friction: it
// decelerates while the state, fresh from rest, falls and the bristle loads.
SmoothCase smooth_case() {
  const InstrumentParams p = fitted();
  SmoothCase c{LateralPlant{p.lateral, p.friction}, {}, {}};
  c.plant.friction.lugre.breakaway_ratio = 0;
  const double load_n = 5e-3;
  c.in.levels = contact_levels(c.plant.friction, load_n, 0.0, 1.0);
  c.in.drive = ideal_drive_field(0.7 * c.in.levels.coulomb_n);
  c.start.velocity_m_per_s = 20e-6;
  c.start.contact_age_s = 50;
  c.start.rate_state_s = p.friction.rate_state.initial_state_s;
  c.start.bristle_m = 0.3 * c.in.levels.coulomb_n / p.friction.lugre.sigma0_n_per_m;
  return c;
}

// Worst error over the run, in newtons: the bristle's and the plate's forces
// (sigma0 z, k x), the velocity's damping force (sigma1 v) and S's state
// term (b N ln phi).
double run_error(const SmoothCase& c, int substeps_held, int substeps_reference, int ticks) {
  LateralState held = c.start, ref = c.start;
  const FrictionModel& m = c.plant.friction;
  double worst = 0;
  for (int k = 0; k < ticks; ++k) {
    integrate_lateral_held(c.plant, c.in, 1e-4, substeps_held, held, nullptr);
    integrate_lateral(c.plant, c.in, 1e-4, substeps_reference, ref);
    const double e = std::max({m.lugre.sigma0_n_per_m * std::fabs(held.bristle_m - ref.bristle_m),
                               c.plant.axis.spring_n_per_m * std::fabs(held.position_m - ref.position_m),
                               m.lugre.sigma1_n_s_per_m * std::fabs(held.velocity_m_per_s - ref.velocity_m_per_s),
                               m.rate_state.state_coeff * c.in.levels.rate_state_n *
                                   std::fabs(std::log(held.rate_state_s / ref.rate_state_s))});
    worst = std::max(worst, e);
  }
  return worst;
}

// The order of the error's fall with the sub-step: halving it divides the
// error by at least min_ratio at every halving.
void expect_order(const SmoothCase& c, double min_ratio) {
  ASSERT_TRUE(held_contact_applies(c.plant));
  double previous = 0;
  for (int n : {1, 2, 4, 8}) {
    const double e = run_error(c, n, 1024, 30);
    std::printf("  %d sub-steps a tick: largest error %.3e N", n, e);
    if (previous > 0) {
      std::printf(" (ratio %.2f)", previous / e);
      EXPECT_GT(previous / e, min_ratio) << n << " sub-steps";
    }
    std::printf("\n");
    previous = e;
  }
}

// The law: second order, halving the sub-step divides the error by about 4
// (at least 3 here), where a first-order treatment of the law gives 2.
TEST(HeldContact, ConvergesAtSecondOrderInTheLaw) {
  const SmoothCase c = smooth_case();
  expect_order(c, 3.0);
  // At one sub-step a tick, from this violent start, below a micronewton (a
  // tenth of the lateral force's noise floor).
  EXPECT_LT(run_error(c, 1, 1024, 30), 1e-6);
}

// With S constant (no rate-and-state, no dwell, Fs = Fc) holding it is
// exact and the plate and bristle converge at RK4's fourth order: a factor
// about 16 per halving (at least 10 here, where a second-order slip in the
// stages gives 4).
TEST(HeldContact, ConvergesAtFourthOrderInThePlateAndBristle) {
  SmoothCase c = smooth_case();
  c.plant.friction.rate_state.enabled = false;
  c.plant.friction.dwell_stiction.enabled = false;
  c.in.levels = contact_levels(c.plant.friction, 5e-3, 0.0, 1.0);
  ASSERT_EQ(c.in.levels.static_n, c.in.levels.coulomb_n);
  expect_order(c, 10.0);
}

// At most two evaluations of S a sub-step, one where the bristle stays
// elastic, and one where holding S moves the friction by less than the
// tolerance (steady sliding).
TEST(HeldContact, EvaluatesTheLawAtMostTwiceASubStep) {
  const InstrumentParams p = fitted();
  const LateralPlant plant{p.lateral, p.friction};
  LateralInputs in;
  in.levels = contact_levels(plant.friction, 5e-3, 0.0, 1.0);
  const double g = in.levels.coulomb_n / p.friction.lugre.sigma0_n_per_m;

  // Stuck, the bristle at half its elastic range, the tip still.
  LateralState stuck;
  stuck.bristle_m = 0.5 * p.friction.lugre.breakaway_ratio * g;
  stuck.rate_state_s = p.friction.rate_state.initial_state_s;
  in.drive = ideal_drive_field(p.friction.lugre.sigma0_n_per_m * stuck.bristle_m);
  int evaluations = 0;
  integrate_lateral_held(plant, in, 1e-4, 3, stuck, nullptr, 0.0, nullptr, &evaluations);
  EXPECT_EQ(evaluations, 3);

  // Sliding at 0.5 um/s in steady state, the drive balancing the friction.
  LateralState sliding;
  const double v = 0.5e-6;
  sliding.velocity_m_per_s = v;
  sliding.rate_state_s = p.friction.rate_state.memory_length_m / (v + p.friction.rate_state.reference_velocity_m_per_s);
  sliding.contact_age_s = p.friction.dwell_stiction.memory_length_m / v;
  sliding.bristle_m = steady_state_friction_n(plant.friction, in.levels, v, 0.0) / p.friction.lugre.sigma0_n_per_m;
  in.drive = ideal_drive_field(steady_state_friction_n(plant.friction, in.levels, v, 0.0));
  evaluations = 0;
  integrate_lateral_held(plant, in, 1e-4, 3, sliding, nullptr, 0.0, nullptr, &evaluations);
  EXPECT_EQ(evaluations, 6) << "without a tolerance: twice a sub-step";
  HeldContactMemory memory;
  evaluations = 0;
  for (int tick = 0; tick < 10; ++tick) {
    integrate_lateral_held(plant, in, 1e-4, 1, sliding, nullptr, 1e-8, &memory, &evaluations);
  }
  EXPECT_EQ(evaluations, 11) << "with a tolerance: twice on the first tick (no estimate yet), then once";
}

}  // namespace
}  // namespace tribo::sim
