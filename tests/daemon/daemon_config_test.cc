#include "daemon/daemon_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "tests/sim/sim_test_support.h"

namespace tribo::daemon {
namespace {

TEST(DaemonConfig, TheShippedConfigIsValid) {
  EXPECT_FALSE(validate_daemon_config(tribo::testing::default_config()));
}

// Dissertation §5.1.1 (eqs. 16-19): a 600 V bias on both plates of A = 1 cm^2 at 85 µm adds
// 2 x 519 N/m of negative stiffness against the 100 N/m spring.
TEST(DaemonConfig, ABiasThatWouldSnapThePlateDownAtRestIsRejected) {
  v1::DaemonConfig c = tribo::testing::default_config();
  c.mutable_transducer()->mutable_normal()->set_bias_v(600);
  const auto e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("transducer.normal.bias_v = 600"), std::string::npos) << *e;
  EXPECT_NE(e->find("1038.06 N/m"), std::string::npos) << *e;
  // A small bias keeps the margin: 50 V adds 14 N/m.
  c.mutable_transducer()->mutable_normal()->set_bias_v(50);
  EXPECT_FALSE(validate_daemon_config(c)) << *validate_daemon_config(c);
}

TEST(DaemonConfig, ErrorsNameTheFieldTheValueAndTheLimit) {
  v1::DaemonConfig c = tribo::testing::default_config();
  c.mutable_supervisor()->set_force_filter_hz(8000);
  auto e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "supervisor.force_filter_hz = 8000: must be in [0.001, 5000]");

  c = tribo::testing::default_config();
  c.mutable_controller()->mutable_normal_force()->set_output_max(-1);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("controller.normal_force.output_min"), std::string::npos) << *e;

  c = tribo::testing::default_config();
  v1::InjectedFault* f = c.mutable_sim()->mutable_faults()->add_faults();
  f->set_kind(v1::ACTUATOR_STUCK);
  f->set_channel(v1::CHANNEL_LATERAL_FORCE);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("sim.faults.faults[0].channel"), std::string::npos) << *e;
}

// A field the schema no longer has (sim.integrator's
// hold_contact_law_over_substeps, number 5 reserved, its name not) is
// refused by name, not silently ignored.
TEST(DaemonConfig, AConfigSettingARemovedFieldIsRefusedByName) {
  const std::string path = ::testing::TempDir() + "removed_field.textproto";
  {
    std::ofstream out(path);
    out << "sim { integrator { method: INTEGRATION_RK4_HELD_CONTACT hold_contact_law_over_substeps: true } }\n";
  }
  v1::DaemonConfig c;
  const auto e = load_daemon_config(path, c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("hold_contact_law_over_substeps"), std::string::npos) << *e;
  std::remove(path.c_str());
}

TEST(DaemonConfig, TheObserversVelocityDelayAndLagAreBoundedAndNeedTheCommandedVelocity) {
  v1::DaemonConfig c = tribo::testing::default_config();
  auto& fc = *c.mutable_controller()->mutable_friction_compensation();
  fc.set_velocity_delay_s(0.075);
  EXPECT_FALSE(validate_daemon_config(c)) << *validate_daemon_config(c);
  fc.set_velocity_delay_s(-0.01);
  auto e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.velocity_delay_s = -0.01: must be in [0, 1]");
  fc.set_velocity_delay_s(1.5);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.velocity_delay_s = 1.5: must be in [0, 1]");
  fc.set_velocity_delay_s(std::nan(""));
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("controller.friction_compensation.velocity_delay_s = nan"), std::string::npos) << *e;
  fc.set_velocity_delay_s(0.075);
  fc.set_velocity_source(v1::MEASURED);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("controller.friction_compensation.velocity_delay_s = 0.075: must be 0 with velocity_source "
                    "MEASURED"),
            std::string::npos)
      << *e;
  fc.set_velocity_delay_s(0);
  fc.set_velocity_lag_s(0.0753);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("controller.friction_compensation.velocity_lag_s = 0.0753: must be 0 with velocity_source MEASURED"),
            std::string::npos)
      << *e;
  fc.set_velocity_source(v1::COMMANDED);
  EXPECT_FALSE(validate_daemon_config(c)) << *validate_daemon_config(c);
  fc.set_velocity_lag_s(-1e-3);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.velocity_lag_s = -0.001: must be in [0, 1]");
  fc.set_velocity_lag_s(2);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.velocity_lag_s = 2: must be in [0, 1]");
}

TEST(DaemonConfig, TheContactStateFromTheMeasuredVelocityNeedsAFilterAndTheCommandedVelocity) {
  v1::DaemonConfig c = testing::default_config();
  auto& fc = *c.mutable_controller()->mutable_friction_compensation();
  fc.set_velocity_lag_s(0.0753);
  fc.set_contact_state_from_measured_velocity(true);
  fc.set_velocity_filter_hz(0);
  auto e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.contact_state_from_measured_velocity = true: needs "
                "velocity_filter_hz > 0, not 0 (unfiltered differences of the readings are noise)");
  fc.set_velocity_filter_hz(50);
  EXPECT_FALSE(validate_daemon_config(c)) << *validate_daemon_config(c);
  fc.set_velocity_lag_s(0);
  fc.set_velocity_source(v1::MEASURED);
  e = validate_daemon_config(c);
  ASSERT_TRUE(e);
  EXPECT_EQ(*e, "controller.friction_compensation.contact_state_from_measured_velocity = true: must be false with "
                "velocity_source MEASURED (every state already follows the measured velocity)");
}

}  // namespace
}  // namespace tribo::daemon
