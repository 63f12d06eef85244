// The Modbus backend against the real tribo-bench process over loopback TCP:
// the lock-step handshake reproduces the simulated backend tick by tick, and
// every injected fault gives a failed IoResult with NaN values and a reason,
// never a stale frame, and the link recovers afterwards.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "daemon/controller.h"
#include "hal/backend_factory.h"
#include "hal/modbus_register_map.h"
#include "hal/sim_transducer.h"
#include "sim/instrument_params.h"
#include "tests/modbus/modbus_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

using hal::IoResult;
using testing::BenchProcess;
using testing::TempDir;

// Timeouts long enough that a stall of this busy machine (up to a few hundred
// ms, measured) is not taken for an injected fault, short enough to keep the
// tests quick.
v1::DaemonConfig test_config() {
  v1::DaemonConfig c = testing::modbus_daemon_config();
  c.mutable_modbus()->set_response_timeout_s(0.5);
  c.mutable_modbus()->set_byte_timeout_s(0.05);
  c.mutable_modbus()->set_max_consecutive_timeouts(3);
  c.mutable_modbus()->set_reconnect_backoff_min_s(0.005);
  c.mutable_modbus()->set_reconnect_backoff_max_s(0.1);
  return c;
}

v1::BenchFault fault(v1::BenchFault::Kind kind, std::uint64_t at_step, std::uint32_t requests) {
  v1::BenchFault f;
  f.set_kind(kind);
  f.set_at_step(at_step);
  f.set_request_count(requests);
  return f;
}

bool all_nan(const hal::SensorFrame& f) {
  return std::isnan(f.lateral_position_m) && std::isnan(f.lateral_force_n) && std::isnan(f.normal_force_n) &&
         std::isnan(f.normal_displacement_m);
}

// The plant at rest under zero drive, as the simulated instrument measures it
// step by step: every step draws new sensor noise, so each frame is unique.
std::vector<sim::Measurement> reference_at_rest(std::uint64_t seed, int steps) {
  const v1::DaemonConfig sim_config = testing::sim_daemon_config();
  sim::SimInstrument instrument(sim::instrument_params_from_config(sim_config.sim()), seed);
  std::vector<sim::Measurement> out{instrument.measurement()};
  for (int i = 0; i < steps; ++i) {
    instrument.step({0, 0}, 1.0 / sim_config.controller().loop_rate_hz());
    out.push_back(instrument.measurement());
  }
  return out;
}

bool same_within_registers(const hal::SensorFrame& f, const sim::Measurement& m) {
  return std::fabs(f.lateral_position_m - m.lateral_position_m) < 1e-14 &&
         std::fabs(f.lateral_force_n - m.lateral_force_n) < 1e-11 &&
         std::fabs(f.normal_force_n - m.normal_force_n) < 1e-11 &&
         std::fabs(f.normal_displacement_m - m.normal_displacement_m) < 1e-14;
}

struct FaultRun {
  std::vector<IoResult> reads, writes;
  int ok_reads = 0;
  int failed_reads_with_values = 0;  // must stay 0: a failure never hands on numbers
  int stale_or_unknown_frames = 0;   // must stay 0: every frame used is a new plant step
  hal::BackendHealth health;
};

// Zero drive for `ticks` ticks of the wall-clock-paced backend; each accepted
// frame is matched against the reference: it must be a later step than the
// previous accepted one.
FaultRun run_with_faults(const std::vector<v1::BenchFault>& faults, int ticks, std::uint64_t seed = 5,
                         v1::DaemonConfig config = test_config()) {
  TempDir dir;
  BenchProcess bench(testing::write_bench_config(dir.path(), config, faults));
  const auto reference = reference_at_rest(seed, ticks + 10);
  auto transducer = hal::make_transducer(testing::with_port(config, bench.port()), seed);
  FaultRun run;
  std::size_t matched = 0;
  bool first = true;
  for (int k = 0; k < ticks; ++k) {
    hal::SensorFrame frame;
    const IoResult r = transducer->read(frame);
    run.reads.push_back(r);
    if (r != IoResult::kOk) {
      if (!all_nan(frame)) ++run.failed_reads_with_values;
    } else {
      ++run.ok_reads;
      std::size_t i = first ? 0 : matched + 1;
      while (i < reference.size() && !same_within_registers(frame, reference[i])) ++i;
      if (i == reference.size()) {
        ++run.stale_or_unknown_frames;
      } else {
        matched = i;
      }
      first = false;
    }
    run.writes.push_back(transducer->write({0, 0}));
    transducer->wait_next_tick();
  }
  run.health = transducer->health();
  return run;
}

int count(const std::vector<IoResult>& v, IoResult r) {
  return static_cast<int>(std::count(v.begin(), v.end(), r));
}

TEST(ModbusBackend, LockStepClosedLoopMatchesTheSimulatedBackendTickByTick) {
  TempDir dir;
  v1::DaemonConfig config = test_config();
  config.mutable_modbus()->set_response_timeout_s(1.0);  // equality is the point, not timing
  BenchProcess bench(testing::write_bench_config(dir.path(), config));
  const v1::DaemonConfig sim_config = testing::sim_daemon_config();
  auto modbus = hal::make_transducer(testing::with_port(config, bench.port()), 11);
  hal::SimTransducer sim(sim::instrument_params_from_config(sim_config.sim()), 11,
                         sim_config.controller().loop_rate_hz(), false);
  daemon::Controller modbus_controller(daemon::controller_params_from_config(config.controller()));
  daemon::Controller sim_controller(daemon::controller_params_from_config(sim_config.controller()));
  // Load to 500 µN and move the tip from 0 to 1 µm: drive, friction and the
  // electrostatic gaps all change.
  const auto& s = sim_config.sim().sensors();
  double sum_dx2 = 0, sum_df2 = 0, max_dx = 0, max_dn = 0;  // dx in steps of the position converter
  for (int k = 0; k < 4000; ++k) {
    daemon::Setpoints sp;
    sp.normal_force_n = std::min(1.0, k / 1000.0) * 500e-6;
    sp.lateral_position_m = k * 0.25e-9;
    hal::SensorFrame a, b;
    ASSERT_EQ(modbus->read(a), IoResult::kOk) << k << ": " << modbus->health().last_error;
    sim.read(b);
    ASSERT_EQ(a.status_bits, b.status_bits);
    const double dx = a.lateral_position_m - b.lateral_position_m, df = a.lateral_force_n - b.lateral_force_n;
    const double steps = dx / testing::lateral_position_step_m(sim_config, b.lateral_position_m);
    sum_dx2 += steps * steps;
    sum_df2 += df * df;
    max_dx = std::max(max_dx, std::fabs(dx));
    max_dn = std::max(max_dn, std::fabs(a.normal_force_n - b.normal_force_n));
    ASSERT_EQ(modbus->write(modbus_controller.step(sp, a).drive), IoResult::kOk) << k;
    sim.write(sim_controller.step(sp, b).drive);
    sim.wait_next_tick();  // steps the simulated plant; the emulator stepped on the write
  }
  // Within quantisation: the map adds < 0.01 pm and 5 pN per count, but a
  // value near a rounding edge of the instrument's own converters may round
  // the other way, and the loop carries that step on for a while. So the
  // lateral channels differ in RMS by less than one step of those converters,
  // and the normal force (its drive is the setpoint, quantised by the DAC)
  // by at most one step of its converter and one count of the map.
  EXPECT_LE(std::sqrt(sum_dx2 / 4000), 1.0);
  EXPECT_LE(std::sqrt(sum_df2 / 4000), s.lateral_force_resolution_n());
  const hal::RegisterMap map = hal::register_map_from_config(config.modbus().register_map());
  EXPECT_LE(max_dn, s.normal_force_resolution_n() + hal::sensor_resolution(map.sensors.normal_force, 0));
  EXPECT_GT(max_dx, 0.0) << "the same numbers: was the map crossed at all?";
  const hal::BackendHealth h = modbus->health();
  EXPECT_TRUE(h.connected);
  EXPECT_EQ(h.errors(), 0u);
  EXPECT_GE(h.transactions, 8000u + 2);  // identity and session, then one read and one write per tick
  EXPECT_GT(h.max_io_s, 0.0);
}

TEST(ModbusBackend, StaleDataFromAFrozenPlantIsNeverUsed) {
  // The device keeps answering but its plant stops: the sequence does not advance.
  const FaultRun run = run_with_faults({fault(v1::BenchFault::FREEZE_PLANT, 50, 5)}, 120);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  // Five acknowledged but frozen writes leave five reads with nothing new.
  EXPECT_EQ(count(run.reads, IoResult::kTimeout), 5);
  EXPECT_EQ(count(run.writes, IoResult::kOk), 120);
  EXPECT_EQ(run.health.bad_frames, 5u);
  EXPECT_NE(run.health.last_error.find("read sensor block: stale data (sequence 50 did not advance)"),
            std::string::npos)
      << run.health.last_error;
  EXPECT_EQ(run.ok_reads, 115);
}

TEST(ModbusBackend, UnansweredRequestsTimeOutAndTheLinkRecovers) {
  const FaultRun run = run_with_faults({fault(v1::BenchFault::STOP_ANSWERING, 50, 2)}, 120);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kTimeout);
  EXPECT_EQ(run.writes[50], IoResult::kTimeout);
  EXPECT_EQ(run.reads[51], IoResult::kOk);  // flushed, answering again, and the frame is new
  EXPECT_EQ(run.health.timeouts, 2u);
  EXPECT_EQ(run.health.link_losses, 0u);
  EXPECT_GE(run.health.max_io_s, 0.5);  // the response timeout
  EXPECT_NE(run.health.last_error.find("write drive block: no answer within the response timeout (500 ms)"),
            std::string::npos)
      << run.health.last_error;
}

TEST(ModbusBackend, TimeoutsInARowCloseTheLinkAndItReconnects) {
  const FaultRun run = run_with_faults({fault(v1::BenchFault::STOP_ANSWERING, 50, 3)}, 400);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.health.timeouts, 3u);  // the third closes the link
  EXPECT_EQ(run.reads[51], IoResult::kLinkDown);
  EXPECT_EQ(run.health.link_losses, 1u);
  EXPECT_GE(run.health.reconnect_attempts, 1u);
  EXPECT_TRUE(run.health.connected);
  EXPECT_GT(count(run.reads, IoResult::kLinkDown), 0);
  EXPECT_EQ(run.reads.back(), IoResult::kOk);
}

TEST(ModbusBackend, ExceptionAnswersFailTheTick) {
  v1::BenchFault f = fault(v1::BenchFault::EXCEPTION, 50, 2);
  f.set_exception_code(4);
  const FaultRun run = run_with_faults({f}, 120);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kTimeout);
  EXPECT_EQ(run.writes[50], IoResult::kTimeout);
  EXPECT_EQ(run.health.exceptions, 2u);
  EXPECT_NE(run.health.last_error.find("write drive block: the device answered with exception 4"),
            std::string::npos)
      << run.health.last_error;
  EXPECT_EQ(run.ok_reads, 119);
}

TEST(ModbusBackend, DroppedConnectionIsReopenedWithBackoff) {
  const FaultRun run = run_with_faults({fault(v1::BenchFault::DROP_CONNECTION, 50, 0)}, 400);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kLinkDown);
  EXPECT_EQ(run.health.link_losses, 1u);
  EXPECT_GE(run.health.reconnect_attempts, 1u);
  EXPECT_TRUE(run.health.connected);
  EXPECT_EQ(run.reads.back(), IoResult::kOk);
  EXPECT_NE(run.health.last_error.find("read sensor block: connection lost"), std::string::npos)
      << run.health.last_error;
}

TEST(ModbusBackend, CorruptValuesAreCaughtByTheChecksum) {
  const FaultRun run = run_with_faults({fault(v1::BenchFault::CORRUPT_VALUES, 50, 2)}, 120);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kTimeout);
  EXPECT_EQ(run.reads[51], IoResult::kTimeout);
  EXPECT_EQ(run.health.bad_frames, 2u);
  // The drive writes after them repeat the last sequence seen: acknowledged, not refused.
  EXPECT_EQ(run.health.exceptions, 0u);
  EXPECT_EQ(run.health.first_error, "read sensor block: corrupt answer (checksum mismatch)");
  EXPECT_EQ(run.ok_reads, 118);
}

TEST(ModbusBackend, LateAnswersAreFlushedNotTakenForLaterOnes) {
  // Two answers 1.2 s late against a 0.5 s timeout: both requests time out;
  // the late answers arrive while later requests wait and must be discarded.
  v1::BenchFault f = fault(v1::BenchFault::SLOW_ANSWERS, 50, 2);
  f.set_delay_s(1.2);
  const FaultRun run = run_with_faults({f}, 200);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kTimeout);
  EXPECT_GE(run.health.timeouts, 1u);
  EXPECT_EQ(run.reads.back(), IoResult::kOk);
}

// One answer 0.8 s late against a 0.5 s timeout: it arrives while the next
// request (the drive write) waits, is refused as that request's answer, and
// the write's own answer may then come after the flush: every later
// transaction would read its predecessor's answer. Malformed answers in a
// row reopen the link, which starts the stream afresh.
TEST(ModbusBackend, AnswersOneBehindReopenTheLinkAndItRecovers) {
  v1::BenchFault f = fault(v1::BenchFault::SLOW_ANSWERS, 50, 1);
  f.set_delay_s(0.8);
  const FaultRun run = run_with_faults({f}, 300);
  EXPECT_EQ(run.stale_or_unknown_frames, 0);
  EXPECT_EQ(run.failed_reads_with_values, 0);
  EXPECT_EQ(run.reads[50], IoResult::kTimeout);
  EXPECT_LE(run.health.bad_frames, 3u) << run.health.last_error;
  for (int k = 200; k < 300; ++k) EXPECT_EQ(run.reads[k], IoResult::kOk) << k << ": " << run.health.last_error;
}

TEST(ModbusBackend, SlowButTimelyAnswersShowInTheMaximumIoTime) {
  v1::BenchFault f = fault(v1::BenchFault::SLOW_ANSWERS, 50, 1);
  f.set_delay_s(0.02);
  const FaultRun run = run_with_faults({f}, 100);
  EXPECT_EQ(count(run.reads, IoResult::kOk), 100);
  EXPECT_EQ(run.health.errors(), 0u);
  EXPECT_GE(run.health.max_io_s, 0.02);  // the delay is a lower bound
}

TEST(ModbusBackend, AnInstrumentWithAnotherSamplePeriodIsRefused) {
  TempDir dir;
  v1::DaemonConfig bench_config = test_config();
  bench_config.mutable_controller()->set_loop_rate_hz(5000);
  BenchProcess bench(testing::write_bench_config(dir.path(), bench_config));
  auto transducer = hal::make_transducer(testing::with_port(test_config(), bench.port()), 1);
  hal::SensorFrame frame;
  EXPECT_EQ(transducer->read(frame), IoResult::kLinkDown);
  EXPECT_TRUE(all_nan(frame));
  EXPECT_EQ(transducer->write({1e-3, 1e-3}), IoResult::kLinkDown);  // never drives it
  const hal::BackendHealth h = transducer->health();
  EXPECT_FALSE(h.connected);
  EXPECT_EQ(h.last_error,
            "read identity block: the device is not the configured instrument (sample period 200000 ns differs "
            "from the loop period)");
}

TEST(ModbusBackend, NoServerMeansLinkDownAndRateLimitedReconnects) {
  // Port 1 on loopback: nothing listens there.
  auto transducer = hal::make_transducer(testing::with_port(test_config(), 1), 1);
  hal::SensorFrame frame;
  int link_down = 0;
  for (int k = 0; k < 300; ++k) {  // 30 ms at 10 kHz
    if (transducer->read(frame) == IoResult::kLinkDown) ++link_down;
    EXPECT_TRUE(all_nan(frame));
    transducer->write({0, 0});
    transducer->wait_next_tick();
  }
  EXPECT_EQ(link_down, 300);
  const hal::BackendHealth h = transducer->health();
  EXPECT_FALSE(h.connected);
  // Backoff 5, 10, 20 ms ...: a handful of attempts, not one per tick.
  EXPECT_GE(h.reconnect_attempts, 1u);
  EXPECT_LE(h.reconnect_attempts, 6u);
  EXPECT_EQ(h.last_error, "connect tcp 127.0.0.1:1 unit 1: Connection refused");
}

}  // namespace
}  // namespace tribo
