// The register map: validation names the entry, the blocks round-trip between
// the backend's and the emulator's sides, and the quantisation budget holds.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "daemon/daemon_config.h"
#include "emulator/bench_config.h"
#include "hal/backend_factory.h"
#include "hal/modbus_blocks.h"
#include "hal/modbus_link.h"
#include "hal/modbus_register_map.h"
#include "proto/text_format_file.h"
#include "tests/modbus/modbus_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

using hal::RegisterMap;

std::string error_of(const v1::DaemonConfig& config) {
  return daemon::validate_daemon_config(config).value_or("");
}

TEST(ModbusConfig, ShippedConfigIsValidAndMatchesTheSimulatedOne) {
  const v1::DaemonConfig modbus = testing::modbus_daemon_config();
  const v1::DaemonConfig sim = testing::sim_daemon_config();
  EXPECT_EQ(hal::backend_name(modbus), "modbus");
  // The controller cannot tell the backends apart: same loop, gains and
  // limits (the Modbus loop thread is pinned beside tribo-bench's server).
  v1::ControllerConfig modbus_controller = modbus.controller();
  EXPECT_EQ(modbus_controller.loop_cpu(), 1);
  modbus_controller.clear_loop_cpu();
  EXPECT_EQ(modbus_controller.SerializeAsString(), sim.controller().SerializeAsString());
  EXPECT_EQ(modbus.limits().SerializeAsString(), sim.limits().SerializeAsString());
  EXPECT_EQ(modbus.server().SerializeAsString(), sim.server().SerializeAsString());
  // The same instrument: the supervisor's nominal transducer constants.
  EXPECT_EQ(modbus.transducer().SerializeAsString(), sim.transducer().SerializeAsString());
}

// The 2 kHz pair is the 10 kHz one but for the loop rate and the lateral
// loop's derivative; tribo-bench-2khz.textproto serves it.
TEST(ModbusConfig, TheTwoKilohertzConfigDiffersOnlyInRateAndDerivative) {
  v1::DaemonConfig slow;
  ASSERT_FALSE(daemon::load_daemon_config(std::string(TRIBO_SOURCE_DIR) + "/config/tribod-modbus-2khz.textproto", slow));
  v1::DaemonConfig fast = testing::modbus_daemon_config();
  EXPECT_EQ(slow.controller().loop_rate_hz(), 2000);
  EXPECT_EQ(slow.controller().lateral_displacement().kd(), 1);
  EXPECT_EQ(slow.controller().lateral_displacement().derivative_filter_hz(), 0);
  auto* c = fast.mutable_controller();
  c->set_loop_rate_hz(2000);
  c->mutable_lateral_displacement()->set_kd(1);
  c->mutable_lateral_displacement()->set_derivative_filter_hz(0);
  EXPECT_EQ(fast.SerializeAsString(), slow.SerializeAsString());
  v1::BenchConfig bench, bench_2khz;
  ASSERT_FALSE(wire::load_text_proto_file(testing::bench_config_path(), bench));
  ASSERT_FALSE(wire::load_text_proto_file(std::string(TRIBO_SOURCE_DIR) + "/config/tribo-bench-2khz.textproto", bench_2khz));
  EXPECT_EQ(bench_2khz.modbus_config_file(), "tribod-modbus-2khz.textproto");
  bench_2khz.set_modbus_config_file(bench.modbus_config_file());
  EXPECT_EQ(bench.SerializeAsString(), bench_2khz.SerializeAsString());
  EXPECT_EQ(bench.realtime_priority(), 10);
  EXPECT_EQ(bench.cpu(), fast.controller().loop_cpu());  // the server beside the loop
}

// tribo-bench checks the register map config's loop on the plant it
// emulates: a config that is stable on its own nominal mass (10 g here) but
// not on the simulated instrument's 1 g is refused, naming both files.
TEST(ModbusConfig, TheBenchChecksTheLoopOnTheEmulatedPlant) {
  testing::TempDir dir;
  v1::DaemonConfig modbus = testing::modbus_daemon_config();
  modbus.mutable_controller()->set_loop_rate_hz(2000);
  modbus.mutable_transducer()->mutable_lateral()->set_moving_mass_kg(10e-3);
  ASSERT_EQ(error_of(modbus), "");
  bench::BenchSetup setup;
  const auto error = bench::load_bench_setup(testing::write_bench_config(dir.path(), modbus).string(), setup);
  ASSERT_TRUE(error);
  EXPECT_NE(error->find("tribod-modbus.textproto on the plant of "), std::string::npos) << *error;
  EXPECT_NE(error->find("controller.lateral_displacement.kd = 5: the sampled lateral displacement loop is unstable at "
                        "controller.loop_rate_hz = 2000 (out of contact, moving mass 0.001 kg"),
            std::string::npos)
      << *error;
  modbus.mutable_controller()->mutable_lateral_displacement()->set_kd(1);
  EXPECT_FALSE(bench::load_bench_setup(testing::write_bench_config(dir.path(), modbus).string(), setup));
}

TEST(ModbusConfig, ValidationNamesTheEntry) {
  const v1::DaemonConfig good = testing::modbus_daemon_config();
  struct Case {
    std::function<void(v1::ModbusConfig&)> change;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->mutable_lateral_force()->set_address(4); },
       "modbus.register_map.sensors.lateral_force.address = 4: overlaps "
       "modbus.register_map.sensors.lateral_position.address (registers 4..5)"},
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->mutable_normal_displacement()->set_address(11); },
       "modbus.register_map.sensors.normal_displacement.address = 11: the value (2 registers) must lie inside "
       "modbus.register_map.sensors [0, 12)"},
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->set_count(126); },
       "modbus.register_map.sensors.count = 126: must be in [1, 125]"},
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->mutable_lateral_force()->clear_type(); },
       "modbus.register_map.sensors.lateral_force.type: not set"},
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->clear_table(); },
       "modbus.register_map.sensors.table: not set"},
      {[](auto& m) {
         m.mutable_register_map()->mutable_sensors()->mutable_lateral_position()->mutable_capacitive()->set_plate_gap_m(
             10e-6);
       },
       "modbus.register_map.sensors.lateral_position.capacitive.plate_gap_m = 1e-05: must exceed "
       "limits.max_lateral_travel_m = 1.5e-05"},
      {[](auto& m) {
         m.mutable_register_map()->mutable_sensors()->mutable_lateral_position()->mutable_capacitive()->set_excitation_v(
             0);
       },
       "modbus.register_map.sensors.lateral_position.capacitive.excitation_v = 0: must be > 0"},
      {[](auto& m) { m.mutable_register_map()->mutable_sensors()->mutable_lateral_position()->set_type(v1::INT16); },
       "modbus.register_map.sensors.lateral_position: full scale too small: limits.max_lateral_travel_m = 1.5e-05 "
       "needs"},
      {[](auto& m) {
         m.mutable_register_map()->mutable_drive()->mutable_normal_force()->set_volts_per_count(1e-9);
       },
       "modbus.register_map.drive.normal_force: full scale too small: limits.max_normal_force_n = 0.01 needs"},
      {[](auto& m) { m.mutable_register_map()->mutable_drive()->mutable_lateral_force()->clear_scale(); },
       "modbus.register_map.drive.lateral_force: no scale"},
      {[](auto& m) { m.mutable_register_map()->mutable_session()->set_address(3); },
       "modbus.register_map.session.address = 3: overlaps modbus.register_map.drive.address (registers 0..5)"},
      {[](auto& m) { m.mutable_register_map()->mutable_identity()->set_address(10); },
       "modbus.register_map.identity.address = 10: overlaps modbus.register_map.sensors.address (registers 0..11)"},
      {[](auto& m) { m.mutable_register_map()->mutable_drive()->set_sequence_address(4); },
       "modbus.register_map.drive.lateral_force.address = 4: overlaps modbus.register_map.drive.sequence_address "
       "(registers 4..5)"},
      {[](auto& m) { m.mutable_tcp()->set_host("localhost"); },
       "modbus.tcp.host = \"localhost\": must be a numeric IPv4 address"},
      {[](auto& m) { m.set_unit_id(0); }, "modbus.unit_id = 0: must be in [1, 247]"},
      {[](auto& m) { m.set_byte_timeout_s(1); }, "modbus.byte_timeout_s = 1: must be in [1e-05, 0.05]"},
      {[](auto& m) { m.clear_tcp(); }, "modbus: no link (set tcp { ... } or rtu { ... })"},
      {[](auto& m) { m.clear_register_map(); }, "modbus.register_map: missing"},
  };
  for (const Case& c : cases) {
    v1::DaemonConfig config = good;
    c.change(*config.mutable_modbus());
    const std::string error = error_of(config);
    EXPECT_EQ(error.rfind(c.expected, 0), 0u) << "got:      " << error << "\nexpected: " << c.expected;
  }
}

TEST(ModbusConfig, RtuIsSelectableAndValidated) {
  v1::DaemonConfig config = testing::modbus_daemon_config();
  const auto parse_error = wire::parse_text_proto(
      "device: \"/dev/ttyUSB0\" baud: 115200 parity: \"E\" data_bits: 8 stop_bits: 1", "rtu",
      *config.mutable_modbus()->mutable_rtu());
  ASSERT_FALSE(parse_error) << *parse_error;
  // A tick is 80 characters of 11 bits on the wire: 115200 baud carries 131 Hz.
  EXPECT_EQ(error_of(config).rfind("controller.loop_rate_hz = 10000: above what modbus.rtu carries, at most 130.9 Hz", 0),
            0u)
      << error_of(config);
  config.mutable_modbus()->mutable_rtu()->set_baud(4000000);  // 4545 Hz
  EXPECT_EQ(error_of(config).rfind("controller.loop_rate_hz = 10000: above what modbus.rtu carries, at most 4545 Hz", 0), 0u)
      << error_of(config);
  config.mutable_controller()->set_loop_rate_hz(4000);
  EXPECT_EQ(error_of(config), "");
  config.mutable_modbus()->mutable_rtu()->set_baud(115200);
  const hal::LinkSettings s = hal::link_settings_from_config(config.modbus());
  EXPECT_TRUE(s.rtu);
  EXPECT_EQ(s.parity, 'E');
  EXPECT_EQ(hal::describe_link(s), "rtu /dev/ttyUSB0 115200 8E1 unit 1");

  const std::vector<std::pair<std::function<void(v1::ModbusRtuLink&)>, std::string>> cases = {
      {[](auto& r) { r.set_baud(12345); }, "modbus.rtu.baud = 12345: not a standard rate"},
      {[](auto& r) { r.set_parity("X"); }, "modbus.rtu.parity = \"X\": must be \"N\", \"E\" or \"O\""},
      {[](auto& r) { r.set_data_bits(9); }, "modbus.rtu.data_bits = 9: must be in [7, 8]"},
      {[](auto& r) { r.set_stop_bits(3); }, "modbus.rtu.stop_bits = 3: must be in [1, 2]"},
      {[](auto& r) { r.clear_device(); }, "modbus.rtu.device is empty"},
  };
  for (const auto& [change, expected] : cases) {
    v1::DaemonConfig bad = config;
    change(*bad.mutable_modbus()->mutable_rtu());
    EXPECT_EQ(error_of(bad).rfind(expected, 0), 0u) << error_of(bad);
  }
}

TEST(RegisterMapBlocks, SensorBlockRoundTripsWithinOneCount) {
  const RegisterMap map = hal::register_map_from_config(testing::modbus_daemon_config().modbus().register_map());
  std::vector<std::uint16_t> block(map.sensors.count);
  const hal::SensorFrame in{997.3e-6, 41.2e-9, -128.7e-6, 9.87654321e-6, 0};
  hal::encode_sensor_block(map, 123456789, 1, in, block.data());
  const hal::SensorBlockValues out = hal::decode_sensor_block(map, block.data());
  EXPECT_EQ(out.sequence, 123456789u);
  EXPECT_EQ(out.status, 1);
  EXPECT_TRUE(out.checksum_ok);
  EXPECT_FALSE(out.over_range);
  EXPECT_NEAR(out.frame.lateral_position_m, in.lateral_position_m,
              hal::sensor_resolution(map.sensors.lateral_position, in.lateral_position_m));
  EXPECT_NEAR(out.frame.lateral_force_n, in.lateral_force_n, 5e-12);
  EXPECT_NEAR(out.frame.normal_force_n, in.normal_force_n, 1e-11);
  EXPECT_NEAR(out.frame.normal_displacement_m, in.normal_displacement_m, 1e-14);
  // The documented layout: sequence in registers 0-1, position counts in 4-5.
  EXPECT_EQ(block[0], 123456789u >> 16);
  EXPECT_EQ(block[1], 123456789u & 0xFFFF);
  const auto counts = static_cast<std::int32_t>(static_cast<std::uint32_t>(block[4]) << 16 | block[5]);
  EXPECT_NEAR(counts * 4.76837158203125e-9, hal::capacitive_sense_voltage(map.sensors.lateral_position.sensor,
                                                                          in.lateral_position_m), 4.8e-9);

  // A flipped bit anywhere in the values is caught by the checksum.
  for (unsigned i : {2u, 4u, 7u, 11u}) {
    std::vector<std::uint16_t> bad = block;
    bad[i] ^= 0x0040;
    EXPECT_FALSE(hal::decode_sensor_block(map, bad.data()).checksum_ok) << i;
  }
}

TEST(RegisterMapBlocks, OverRangeReadingIsNotAMeasurement) {
  const RegisterMap map = hal::register_map_from_config(testing::modbus_daemon_config().modbus().register_map());
  std::vector<std::uint16_t> block(map.sensors.count);
  // 20 mN lateral force exceeds the ±10.24 mN channel: the ADC sits at its rail.
  hal::encode_sensor_block(map, 1, 0, hal::SensorFrame{0, 0, 20e-3, 1e-6, 0}, block.data());
  const hal::SensorBlockValues v = hal::decode_sensor_block(map, block.data());
  EXPECT_TRUE(v.over_range);
  EXPECT_TRUE(std::isnan(v.frame.lateral_force_n));
  EXPECT_NEAR(v.frame.lateral_position_m, 1e-6, 1e-14);
}

// The shipped drive block carries force setpoints: the electrostatic law
// (bias, plate choice, gap) is applied by the instrument's electronics behind
// it, so the value does not depend on where either side thinks the plate is.
TEST(RegisterMapBlocks, DriveRoundTripsAsForceSetpoints) {
  const RegisterMap map = hal::register_map_from_config(testing::modbus_daemon_config().modbus().register_map());
  std::vector<std::uint16_t> block(map.drive.count);
  const hal::AxisPositions at{6.5e-6, 30e-9}, elsewhere{-3e-6, 0};
  for (const hal::DriveCommand command : {hal::DriveCommand{1000e-6, 882.4e-6}, hal::DriveCommand{0, -1.3e-3},
                                          hal::DriveCommand{9.99e-3, 4.99e-3}, hal::DriveCommand{0, 0}}) {
    ASSERT_TRUE(hal::encode_drive_block(map, 42, command, at, block.data()));
    const hal::DriveBlockValues back = hal::decode_drive_block(map, block.data(), elsewhere);
    EXPECT_EQ(back.sequence, 42u);
    // Within half a DAC count (4.77 nV): 2.4 pN lateral at 1 mN/V, 4.8 pN normal at 2 mN/V.
    EXPECT_NEAR(back.command.normal_force_n, command.normal_force_n, 4.8e-12);
    EXPECT_NEAR(back.command.lateral_force_n, command.lateral_force_n, 2.4e-12);
  }
  // The documented layout: lateral counts in registers 4-5, 1 mN/V over 10.24 V / 2^31.
  ASSERT_TRUE(hal::encode_drive_block(map, 1, {0, 1e-3}, at, block.data()));
  EXPECT_EQ(static_cast<std::int32_t>(static_cast<std::uint32_t>(block[4]) << 16 | block[5]), 209715200);
}

// The map can also describe an instrument whose drive register is the
// voltage of the pulling plate of an unbiased drive (dissertation §5.1.1): then
// the backend solves the law at its measured position, the plate feels it at
// the true one, and a position error dx changes the force by 2 dx / gap.
TEST(RegisterMapBlocks, AnElectrostaticDriveChannelRoundTripsThroughThePlateLaw) {
  v1::ModbusRegisterMap config = testing::modbus_daemon_config().modbus().register_map();
  for (v1::DriveChannel* c : {config.mutable_drive()->mutable_normal_force(),
                              config.mutable_drive()->mutable_lateral_force()}) {
    c->set_volts_per_count(1000.0 / 2147483648.0);  // ±1000 V
    auto* e = c->mutable_electrostatic();
    e->set_permittivity_f_per_m(8.854e-12);
    e->set_plate_area_m2(1e-4);
    e->set_plate_gap_m(85e-6);
  }
  const RegisterMap map = hal::register_map_from_config(config);
  std::vector<std::uint16_t> block(map.drive.count);
  const hal::AxisPositions at{6.5e-6, 30e-9};
  for (const hal::DriveCommand command : {hal::DriveCommand{1000e-6, 882.4e-6}, hal::DriveCommand{0, -1.3e-3},
                                          hal::DriveCommand{9.99e-3, 4.99e-3}, hal::DriveCommand{0, 0}}) {
    ASSERT_TRUE(hal::encode_drive_block(map, 42, command, at, block.data()));
    const hal::DriveBlockValues back = hal::decode_drive_block(map, block.data(), at);
    // One DAC count (0.47 µV) in hundreds of volts: a few pN.
    EXPECT_NEAR(back.command.normal_force_n, command.normal_force_n, 1e-11);
    EXPECT_NEAR(back.command.lateral_force_n, command.lateral_force_n, 1e-11);
  }
  ASSERT_TRUE(hal::encode_drive_block(map, 1, {0, 1e-3}, at, block.data()));
  const hal::AxisPositions moved{at.lateral_position_m + 1e-9, at.normal_displacement_m};
  const double force = hal::decode_drive_block(map, block.data(), moved).command.lateral_force_n;
  EXPECT_NEAR(force / 1e-3 - 1, 2 * 1e-9 / (85e-6 - 6.5e-6 - 1e-9), 1e-8);
}

TEST(RegisterMapBlocks, QuantisationBudget) {
  const v1::DaemonConfig config = testing::modbus_daemon_config();
  const RegisterMap map = hal::register_map_from_config(config.modbus().register_map());
  // The shipped map adds < 0.01 pm of position over the whole travel, more
  // than two orders below the instrument's own position converter (2 pm at
  // x = 0, growing with |x|: tests/modbus/modbus_support.h).
  const v1::DaemonConfig physics = testing::sim_daemon_config();
  for (double x : {-15e-6, 0.0, 2e-6, 10e-6, 15e-6}) {
    EXPECT_LT(hal::sensor_resolution(map.sensors.lateral_position, x), 0.01e-12) << x;
    EXPECT_LT(hal::sensor_resolution(map.sensors.lateral_position, x),
              0.01 * testing::lateral_position_step_m(physics, x))
        << x;
  }
  EXPECT_LT(hal::sensor_resolution(map.sensors.lateral_force, 0), 1e-11);
  EXPECT_LT(hal::sensor_resolution(map.sensors.normal_force, 0), 1e-10);
  // A 16-bit ADC over the same ±10.24 V would step by 0.5 nm: the step that
  // biases friction by -5 % in this loop (see ModbusQuantisation tests).
  v1::ModbusRegisterMap coarse = config.modbus().register_map();
  auto* lp = coarse.mutable_sensors()->mutable_lateral_position();
  lp->set_type(v1::INT16);
  lp->set_volts_per_count(10.24 / 32768);
  const RegisterMap coarse_map = hal::register_map_from_config(coarse);
  EXPECT_NEAR(hal::sensor_resolution(coarse_map.sensors.lateral_position, 0), 0.51e-9, 0.01e-9);
}

}  // namespace
}  // namespace tribo
