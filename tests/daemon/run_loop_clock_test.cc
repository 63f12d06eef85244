// An unpaced run reads no clock (issue 17): with time_stages off the loop
// never calls its clock, and its samples are those of a timed run bit for
// bit; with time_stages on (tribod) it reads six times a tick, which is what
// makes the count meaningful.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

std::uint64_t clock_reads = 0;

std::uint64_t counting_clock() { return ++clock_reads; }

struct ClockedRun {
  std::vector<Sample> samples;
  std::uint64_t cycles = 0;
  std::uint64_t reads = 0;
  StageSnapshot tick_stage;
};

ClockedRun run_standard_scratch(bool time_stages) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const ProtocolCheck check = validate_protocol(testing::load_protocol_file("standard_scratch.textproto"), config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  auto transducer = hal::make_transducer(config, 5);
  SpscQueue<Sample> queue(1 << 12);
  RunControl control;
  RunTelemetry telemetry;
  RunLoopConfig loop_config = run_loop_config_from(config);
  loop_config.time_stages = time_stages;
  loop_config.clock_ns = &counting_clock;
  RunLoop loop(*transducer, check.load_function, loop_config, queue, control, telemetry);
  ClockedRun run;
  clock_reads = 0;
  Sample sample;
  for (int k = 0; k < 20000 && loop.tick(); ++k) {  // 2 s: approach and the start of the load
    while (queue.try_pop(sample)) run.samples.push_back(sample);
  }
  run.reads = clock_reads;
  run.cycles = telemetry.cycles.load();
  run.tick_stage = telemetry.timing.snapshot(Stage::kTick);
  return run;
}

TEST(RunLoopClock, AnUntimedRunReadsNoClockAndRecordsTheSameSamples) {
  const ClockedRun untimed = run_standard_scratch(false);
  const ClockedRun timed = run_standard_scratch(true);
  EXPECT_EQ(untimed.cycles, 20000u);
  EXPECT_EQ(untimed.reads, 0u);
  EXPECT_EQ(untimed.tick_stage.total_ns, 0u);
  EXPECT_EQ(timed.reads, 6 * timed.cycles);
  EXPECT_GT(timed.tick_stage.total_ns, 0u);
  ASSERT_EQ(untimed.samples.size(), timed.samples.size());
  EXPECT_TRUE(untimed.samples == timed.samples);
}

TEST(RunLoopClock, TribodTimesItsStages) {
  EXPECT_TRUE(run_loop_config_from(tribo::testing::default_config()).time_stages);
}

}  // namespace
}  // namespace tribo::daemon
