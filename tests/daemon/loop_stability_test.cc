// The discrete-time stability checks at config load (daemon/loop_stability.h):
// the closed-loop poles against the textbook conditions, and a config whose
// loop would be unstable at its loop rate refused naming the field, the value
// and the limit.
#include "daemon/loop_stability.h"

#include <gtest/gtest.h>

#include "daemon/daemon_config.h"
#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::daemon {
namespace {

std::string error_of(const v1::DaemonConfig& c) { return validate_daemon_config(c).value_or(""); }

v1::DaemonConfig shipped(const std::string& name) {
  v1::DaemonConfig c;
  if (auto e = load_daemon_config(std::string(TRIBO_SOURCE_DIR) + "/config/" + name, c)) throw std::runtime_error(*e);
  return c;
}

// A free mass under derivative feedback alone: its velocity obeys
// z^2 - (1 - a/2) z + a/2 with a = kd dt / m, stable exactly for a < 2
// (Jury). (Its position and the unused integral stay on the unit circle.)
TEST(LoopStability, AFreeMassUnderDAloneIsStableBelowKdDtOverMEqualTwo) {
  const LateralPlant mass{1e-3, 0, 0};
  const double dt = 1e-4;
  PidGains d;
  d.kd = 1.99 * mass.mass_kg / dt;
  EXPECT_LE(lateral_loop_spectral_radius(d, mass, dt), 1 + 1e-9);
  d.kd = 2.01 * mass.mass_kg / dt;
  EXPECT_NEAR(lateral_loop_spectral_radius(d, mass, dt), std::sqrt(2.01 / 2), 1e-9);
}

// An integral loop on a plant that answers a tick later with gain g: its
// pole is 1 - g ki dt, stable for g ki dt < 2.
TEST(LoopStability, AnIntegralLoopOnADelayedGainIsStableBelowGKiDtEqualTwo) {
  PidGains i;
  const double dt = 1e-3;
  i.ki = 1.9 / dt;
  EXPECT_NEAR(delayed_gain_loop_spectral_radius(i, 1.0, dt), 0.9, 1e-9);
  i.ki = 2.1 / dt;
  EXPECT_NEAR(delayed_gain_loop_spectral_radius(i, 1.0, dt), 1.1, 1e-9);
  EXPECT_LT(delayed_gain_loop_spectral_radius(i, 0.5, dt), 1.0);  // half the gain: ki dt g = 1.05
}

// config/tribod.textproto at 2 kHz: kd = 5 N s/m (kd dt / m = 2.5) is
// refused; the limit with kp = 420, ki = 7116 and the 1 kHz filter is 3.59.
TEST(LoopStability, TheDefaultGainsAtTwoKilohertzAreRefusedNamingKdAndItsLimit) {
  v1::DaemonConfig c = tribo::testing::default_config();
  EXPECT_EQ(error_of(c), "");
  c.mutable_controller()->set_loop_rate_hz(2000);
  const std::string e = error_of(c);
  EXPECT_EQ(e.rfind("controller.lateral_displacement.kd = 5: the sampled lateral displacement loop is unstable at "
                    "controller.loop_rate_hz = 2000 (out of contact",
                    0),
            0u)
      << e;
  EXPECT_NE(e.find("kd must be below 3.59"), std::string::npos) << e;
  c.mutable_controller()->mutable_lateral_displacement()->set_kd(3.5);
  EXPECT_EQ(error_of(c), "");
  c.mutable_controller()->mutable_lateral_displacement()->set_kd(3.7);
  EXPECT_NE(error_of(c), "");
}

// The force and normal loops at 1 kHz: ki dt g above 2 is refused, naming ki.
TEST(LoopStability, TheForceAndNormalLoopsAreCheckedToo) {
  v1::DaemonConfig c = tribo::testing::default_config();
  c.mutable_controller()->set_loop_rate_hz(1000);
  c.mutable_controller()->mutable_lateral_displacement()->set_kd(0.5);  // limit 1.16 at 1 kHz
  EXPECT_EQ(error_of(c), "");
  c.mutable_controller()->mutable_lateral_force()->set_ki(2500);  // ki dt = 2.5, gain 1
  std::string e = error_of(c);
  EXPECT_EQ(e.rfind("controller.lateral_force.ki = 2500: the sampled lateral force loop is unstable", 0), 0u) << e;
  EXPECT_NE(e.find("ki must be below 2e+03"), std::string::npos) << e;
  c.mutable_controller()->mutable_lateral_force()->set_ki(1500);
  c.mutable_controller()->mutable_normal_displacement()->set_ki(2.5e5);  // ki dt / k = 2.5
  e = error_of(c);
  EXPECT_EQ(e.rfind("controller.normal_displacement.ki = 250000", 0), 0u) << e;
  EXPECT_NE(e.find("ki must be below 2e+05"), std::string::npos) << e;
  c.mutable_controller()->mutable_normal_displacement()->set_ki(1.5e5);
  c.mutable_controller()->mutable_normal_force()->set_kp(1.2);  // the delayed reading feeds back -kp
  e = error_of(c);
  EXPECT_EQ(e.rfind("controller.normal_force.kp = 1.2", 0), 0u) << e;
}

// With the tip stuck the contact's stiffness joins the plate's: a stiff
// contact without damping of its own (1e5 N/m, sigma1 = 0) makes the default
// loop unstable at 10 kHz though the free plate's is stable.
TEST(LoopStability, TheSimulatedContactIsAPlantToo) {
  v1::DaemonConfig c = tribo::testing::default_config();
  c.mutable_sim()->mutable_friction()->set_contact_stiffness_n_per_m(1e5);
  c.mutable_sim()->mutable_friction()->set_bristle_damping_n_s_per_m(0);
  const std::string e = error_of(c);
  EXPECT_EQ(e.rfind("controller.lateral_displacement: the sampled lateral displacement loop is unstable", 0), 0u) << e;
  EXPECT_NE(e.find("tip stuck on the sample"), std::string::npos) << e;
}

// A backend other than the simulated one is checked on the transducer's
// nominal constants, which then need the moving mass.
TEST(LoopStability, TheModbusConfigIsCheckedOnItsNominalMass) {
  v1::DaemonConfig c = shipped("tribod-modbus.textproto");
  EXPECT_EQ(error_of(c), "");
  c.mutable_transducer()->mutable_lateral()->clear_moving_mass_kg();
  EXPECT_EQ(error_of(c).rfind("transducer.lateral.moving_mass_kg = 0: must be > 0", 0), 0u) << error_of(c);
  c = shipped("tribod-modbus.textproto");
  c.mutable_controller()->set_loop_rate_hz(2000);
  EXPECT_EQ(error_of(c).rfind("controller.lateral_displacement.kd = 5", 0), 0u) << error_of(c);
  EXPECT_NE(error_of(c).find("transducer's nominal constants"), std::string::npos) << error_of(c);
}

// Every shipped daemon config loads (so passes its own stability check).
TEST(LoopStability, EveryShippedConfigIsStable) {
  for (const char* name : {"tribod.textproto", "tribod-modbus.textproto", "tribod-modbus-2khz.textproto",
                           "instruments/lugre_plain.textproto", "instruments/appendix_c.textproto",
                           "instruments/dissertation_fit.textproto"}) {
    EXPECT_NO_THROW(shipped(name)) << name;
  }
}

}  // namespace
}  // namespace tribo::daemon
