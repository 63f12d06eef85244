// An unpaced run reads no clock: with time_stages_every 0 the loop
// never calls its clock, and its samples are those of a timed run bit for
// bit; timing every tick (tribod's paced loops) it reads six times a tick,
// which is what makes the count meaningful; tribod's unpaced simulated runs
// time one tick in kUnpacedTimingInterval.
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
  std::uint64_t timed_ticks = 0;
  StageSnapshot tick_stage;
};

ClockedRun run_standard_scratch(std::uint32_t time_stages_every) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const ProtocolCheck check = validate_protocol(testing::load_protocol_file("standard_scratch.textproto"), config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  auto transducer = hal::make_transducer(config, 5);
  SpscQueue<Sample> queue(1 << 12);
  RunControl control;
  RunTelemetry telemetry;
  RunLoopConfig loop_config = run_loop_config_from(config);
  loop_config.time_stages_every = time_stages_every;
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
  run.timed_ticks = telemetry.timing.ticks();
  run.tick_stage = telemetry.timing.snapshot(Stage::kTick);
  return run;
}

TEST(RunLoopClock, AnUntimedRunReadsNoClockAndRecordsTheSameSamples) {
  const ClockedRun untimed = run_standard_scratch(0);
  const ClockedRun timed = run_standard_scratch(1);
  EXPECT_EQ(untimed.cycles, 20000u);
  EXPECT_EQ(untimed.reads, 0u);
  EXPECT_EQ(untimed.tick_stage.total_ns, 0u);
  EXPECT_EQ(timed.reads, 6 * timed.cycles);
  EXPECT_EQ(timed.timed_ticks, timed.cycles);
  EXPECT_GT(timed.tick_stage.total_ns, 0u);
  ASSERT_EQ(untimed.samples.size(), timed.samples.size());
  EXPECT_TRUE(untimed.samples == timed.samples);
}

TEST(RunLoopClock, TribodsUnpacedRunsTimeOneTickInTheInterval) {
  const ClockedRun sampled = run_standard_scratch(kUnpacedTimingInterval);
  const std::uint64_t timed = (sampled.cycles + kUnpacedTimingInterval - 1) / kUnpacedTimingInterval;  // ticks 0, N, 2N...
  EXPECT_EQ(sampled.timed_ticks, timed);
  EXPECT_EQ(sampled.reads, 6 * timed);
  EXPECT_GT(sampled.tick_stage.max_ns, 0u);
  EXPECT_TRUE(sampled.samples == run_standard_scratch(0).samples);
}

TEST(RunLoopClock, PacedLoopsTimeEveryTick) {
  EXPECT_EQ(run_loop_config_from(tribo::testing::default_config()).time_stages_every, 1u);
}

}  // namespace
}  // namespace tribo::daemon
