// Clients not written here read tribo-bench's registers as docs/modbus.md documents
// the map: Debian's python3-pymodbus (tests/modbus/third_party_client.py,
// which decodes the values with its own implementation of the documented
// scaling and pymodbus's CRC) and mbpoll.
#include <gtest/gtest.h>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <cmath>

#include "hal/modbus_blocks.h"
#include "sim/instrument_params.h"
#include "tests/modbus/modbus_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

using google::protobuf::Struct;
using testing::BenchProcess;
using testing::TempDir;

const std::string kScript = std::string(TRIBO_SOURCE_DIR) + "/tests/modbus/third_party_client.py";

double field(const Struct& s, const std::string& name) { return s.fields().at(name).number_value(); }
const Struct& child(const Struct& s, const std::string& name) { return s.fields().at(name).struct_value(); }

void expect_measurement(const Struct& got, const sim::Measurement& m, const std::string& what) {
  // pymodbus decodes with numpy's root finder: good to 1e-13 m here, far
  // below the instrument's 1.8 pm; forces to a register count.
  EXPECT_NEAR(field(got, "lateral_position_m"), m.lateral_position_m, 1e-13) << what;
  EXPECT_NEAR(field(got, "normal_displacement_m"), m.normal_displacement_m, 1e-13) << what;
  EXPECT_NEAR(field(got, "lateral_force_n"), m.lateral_force_n, 1e-11) << what;
  EXPECT_NEAR(field(got, "normal_force_n"), m.normal_force_n, 1e-11) << what;
  EXPECT_TRUE(got.fields().at("checksum_ok").bool_value()) << what << ": pymodbus's CRC-16 disagrees";
}

TEST(ThirdPartyClient, PymodbusReadsAndDrivesTheEmulatorAsDocumented) {
  TempDir dir;
  BenchProcess bench(testing::write_bench_config(dir.path(), testing::modbus_daemon_config()));
  const auto result = testing::run_command({PYTHON3_PATH, kScript, std::to_string(bench.port())});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  Struct out;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(result.out, &out).ok()) << result.out;

  EXPECT_EQ(field(out, "magic"), 0x54524942);  // "TRIB"
  EXPECT_EQ(field(out, "map_version"), 1);
  EXPECT_EQ(field(out, "sample_period_ns"), 100000);  // 10 kHz, the loop rate of the config

  const v1::DaemonConfig physics = testing::sim_daemon_config();
  const sim::InstrumentParams params = sim::instrument_params_from_config(physics.sim());
  // Before any session: the plant at rest with the physics config's seed.
  const sim::SimInstrument initial(params, physics.sim().seed());
  EXPECT_EQ(field(child(out, "initial"), "sequence"), 0);
  expect_measurement(child(out, "initial"), initial.measurement(), "initial");

  // After the session write (seed 7, reset) and one drive write of 0.1 mN
  // lateral with sequence 1: the plant stepped exactly once.
  sim::SimInstrument seven(params, 7);
  expect_measurement(child(out, "after_reset"), seven.measurement(), "after reset");
  EXPECT_EQ(field(child(out, "after_reset"), "sequence"), 0);
  seven.step({0, field(out, "lateral_drive_n")}, 1e-4);
  EXPECT_EQ(field(child(out, "after_step"), "sequence"), 1);
  const Struct& stepped = child(out, "after_step");
  // The force setpoint crossed the DAC exactly (0.1 mN is a whole number of
  // 4.8 pN counts): the emulated instrument took the step the simulated one did.
  expect_measurement(stepped, seven.measurement(), "after one step");
  EXPECT_GT(seven.truth().lateral.position_m, 3e-10) << "0.1 mN for 100 µs moves the plate";

  EXPECT_FALSE(out.fields().at("repeat_is_error").bool_value());
  EXPECT_EQ(field(out, "after_repeat_sequence"), 1) << "a repeated drive write must not step";
  EXPECT_EQ(field(out, "out_of_sequence_exception"), 3);  // ILLEGAL DATA VALUE
}

TEST(ThirdPartyClient, MbpollReadsTheIdentityBlock) {
  TempDir dir;
  BenchProcess bench(testing::write_bench_config(dir.path(), testing::modbus_daemon_config()));
  // mbpoll counts references from 1: input registers 100-104 are 101-105.
  const auto r = testing::run_command({MBPOLL_PATH, "-m", "tcp", "-a", "1", "-t", "3:hex", "-r", "101", "-c", "5",
                                       "-1", "-p", std::to_string(bench.port()), "127.0.0.1"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* line : {"[101]: \t0x5452", "[102]: \t0x4942", "[103]: \t0x0001", "[104]: \t0x0001",
                           "[105]: \t0x86A0"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line << " missing in\n" << r.out;
  }
}

}  // namespace
}  // namespace tribo
