// The specialised RK4 path (sim/compact_rk4.h) against the general one: the
// same bits in every state after every tick, on the plant combinations it
// serves (dwell and rate-and-state on and off, RK4 and midpoint, one and
// several sub-steps, an ideal and an electrostatic drive with stops, in and
// out of contact, across stick, the elasto-plastic blend and sliding), and
// it stays out of the plants and states it does not serve.
#include "sim/compact_rk4.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "daemon/daemon_config.h"
#include "sim/instrument_params.h"
#include "sim/noise_source.h"

namespace tribo::sim {
namespace {

// The compact path serves the fitted contact's law (the direct effect on the
// tip's velocity); the default's direct effect on the slip rate takes the
// general path (compact_rk4_applies).
LateralPlant fitted_plant() {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/config/instruments/fitted_contact.textproto";
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  const InstrumentParams p = instrument_params_from_config(config.sim());
  return LateralPlant{p.lateral, p.friction};
}

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

void expect_same_bits(const LateralState& a, const LateralState& b, const std::string& where) {
  const double fa[] = {a.position_m, a.velocity_m_per_s, a.tip_position_m, a.tip_velocity_m_per_s, a.bristle_m,
                       a.lag_velocity_m_per_s, a.contact_age_s, a.rate_state_s};
  const double fb[] = {b.position_m, b.velocity_m_per_s, b.tip_position_m, b.tip_velocity_m_per_s, b.bristle_m,
                       b.lag_velocity_m_per_s, b.contact_age_s, b.rate_state_s};
  for (int i = 0; i < 8; ++i) ASSERT_EQ(bits(fa[i]), bits(fb[i])) << where << ", field " << i;
}

TEST(CompactRk4, SameBitsAsTheGeneralPath) {
  NoiseSource random(17);
  int ticks = 0, in_blend = 0, stuck = 0, stopped = 0;
  for (int combo = 0; combo < 4; ++combo) {
    LateralPlant plant = fitted_plant();
    plant.friction.dwell_stiction.enabled = combo & 2;
    plant.friction.rate_state.enabled = combo & 1;
    for (int trial = 0; trial < 60; ++trial) {
      const double load_n = trial % 10 == 9 ? 0.0 : 1e-4 + 1e-2 * random.uniform();
      const FrictionLevels levels = contact_levels(plant.friction, load_n, 0.0, 1.0);
      LateralInputs in;
      in.levels = levels;
      in.tip_force_n = load_n * 0.026;
      in.sample_velocity_m_per_s = trial % 3 == 0 ? 0.0 : 1e-9 * random.gaussian();
      in.sample_offset_m = 1e-7 * random.gaussian();
      // An ideal drive, or plates with stops 3 um away (the plate may reach them).
      in.drive = trial % 2 == 0 ? ideal_drive_field(2e-3 * random.gaussian())
                                : DriveField{0, 6e-11 * random.uniform(), 6e-11 * random.uniform(), 8e-6, 8e-6, 5e-6};
      const double g = levels.in_contact() ? levels.static_n / plant.friction.lugre.sigma0_n_per_m : 1e-7;
      LateralState s;
      s.position_m = 2e-6 * random.gaussian();
      s.velocity_m_per_s = trial % 4 == 0 ? 0.0 : 2e-5 * random.gaussian();
      s.bristle_m = 1.2 * g * (2 * random.uniform() - 1);
      s.contact_age_s = 100 * random.uniform();
      s.rate_state_s = 0.2 * random.uniform();
      s.tip_position_m = s.position_m;
      s.tip_velocity_m_per_s = s.velocity_m_per_s;
      const SubstepScheme scheme = trial % 5 == 4 ? SubstepScheme::kMidpoint : SubstepScheme::kRk4;
      const int substeps = trial % 7 == 3 ? 3 : 1;
      LateralState general = s;
      for (int tick = 0; tick < 50; ++tick) {
        ASSERT_TRUE(compact_rk4_applies(plant, s));
        const LateralRate first = lateral_derivative(plant, in, s).rate;
        const bool a = integrate_lateral(plant, in, 1e-4, substeps, s, tick % 2 ? &first : nullptr, scheme);
        const bool b = integrate_lateral_general(plant, in, 1e-4, substeps, general, tick % 2 ? &first : nullptr, scheme);
        const std::string where = "combo " + std::to_string(combo) + ", trial " + std::to_string(trial) +
                                  ", tick " + std::to_string(tick);
        ASSERT_EQ(a, b) << where;
        expect_same_bits(s, general, where);
        s.tip_position_m = general.tip_position_m = s.position_m;  // as advance_lateral does
        s.tip_velocity_m_per_s = general.tip_velocity_m_per_s = s.velocity_m_per_s;
        const double gz = std::fabs(s.bristle_m) / g;
        in_blend += levels.in_contact() && gz > plant.friction.lugre.breakaway_ratio && gz < 1.0;
        stuck += levels.in_contact() && gz <= plant.friction.lugre.breakaway_ratio;
        stopped += a;
        ++ticks;
      }
    }
  }
  // The comparison covered the regimes, not only one of them.
  EXPECT_GT(in_blend, 100) << "of " << ticks;
  EXPECT_GT(stuck, 100) << "of " << ticks;
  EXPECT_GT(stopped, 10) << "of " << ticks;
}

TEST(CompactRk4, StaysOutOfThePlantsAndStatesItDoesNotServe) {
  const LateralPlant fitted = fitted_plant();
  LateralState s;
  EXPECT_TRUE(compact_rk4_applies(fitted, s));
  LateralPlant other = fitted;
  other.axis.backlash.enabled = true;
  EXPECT_FALSE(compact_rk4_applies(other, s));
  other = fitted;
  other.friction.presliding_hysteresis.enabled = true;
  EXPECT_FALSE(compact_rk4_applies(other, s));
  other = fitted;
  other.friction.frictional_lag.enabled = true;
  EXPECT_FALSE(compact_rk4_applies(other, s));
  // A state the general path would turn from -0 into +0 (h x 0 added).
  other = fitted;
  other.friction.dwell_stiction.enabled = false;
  s.contact_age_s = -0.0;
  EXPECT_FALSE(compact_rk4_applies(other, s));
  EXPECT_TRUE(compact_rk4_applies(fitted, s));  // there the age is integrated
  s = LateralState{};
  s.tip_velocity_m_per_s = -0.0;
  EXPECT_FALSE(compact_rk4_applies(fitted, s));
}

}  // namespace
}  // namespace tribo::sim
