// An emergency stop acts within one loop period whatever the supervised
// loop runs. The loop's paced sleep is interruptible (a wake ends
// it before its deadline), and an emergency stop during each activity (a
// run, its stop sequence, autotune, the re-arm check), or after a run's last
// tick, latches FAULTED. No assertion here is on a duration: the latencies
// are figures of bench/estop_latency_bench.cc.
#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "hal/last_drive_transducer.h"
#include "hal/tick_wake.h"
#include "hal/wall_clock_pacer.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

using testing::parse_protocol;
using testing::ServiceFixture;

// ------------------------------------------------------------ the wake

TEST(TickWake, AWakeEndsAPacedWaitBeforeItsDeadline) {
  hal::TickWake wake;
  // A 1000 s period: a wait that returns did not reach its deadline.
  hal::WallClockPacer pacer(1000.0, &wake);
  std::promise<bool> woken;
  std::thread loop([&] { woken.set_value(pacer.wait()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // most likely asleep by now (pending works too)
  wake.wake();
  EXPECT_TRUE(woken.get_future().get()) << "the wait says it reached its deadline";
  loop.join();
  EXPECT_EQ(wake.wakes(), 1u);
  EXPECT_EQ(pacer.overruns(), 0u);
}

TEST(TickWake, AWakeBeforeTheWaitIsNotLostAndEndsOneWaitOnly) {
  hal::TickWake wake;
  wake.wake();
  EXPECT_TRUE(wake.wait_until(hal::monotonic_ns() + 1'000'000'000'000));  // 1000 s: only the wake ends it
  // Consumed: the next wait runs to its (near) deadline.
  EXPECT_FALSE(wake.wait_until(hal::monotonic_ns() + 1'000'000));
  EXPECT_EQ(wake.wakes(), 1u);
}

// A backend whose writes succeed or fail on demand.
class ScriptedWrites final : public hal::Transducer {
 public:
  explicit ScriptedWrites(bool* ok) : ok_(ok) {}
  std::string_view backend_name() const override { return "scripted"; }
  double period_s() const override { return 1e-4; }
  hal::IoResult read(hal::SensorFrame&) override { return hal::IoResult::kOk; }
  hal::IoResult write(const hal::DriveCommand&) override { return *ok_ ? hal::IoResult::kOk : hal::IoResult::kTimeout; }
  void wait_next_tick() override {}
  void interrupt_wait() override {}

 private:
  bool* ok_;
};

TEST(LastDriveTransducer, RemembersOnlyAcknowledgedDrives) {
  bool ok = true;
  hal::LastDriveTransducer t(std::make_unique<ScriptedWrites>(&ok));
  EXPECT_EQ(t.last_drive().normal_force_n, 0);
  ASSERT_EQ(t.write({1e-3, 2e-4}), hal::IoResult::kOk);
  ok = false;
  // Not acknowledged: the instrument still holds 1 mN, the stop starts there.
  EXPECT_EQ(t.write({5e-3, 0}), hal::IoResult::kTimeout);
  EXPECT_EQ(t.last_drive().normal_force_n, 1e-3);
  EXPECT_EQ(t.last_drive().lateral_force_n, 2e-4);
}

// ------------------------------------------------ the activities

// A paced loop: the loop's wait is a real sleep the wake must cut short.
v1::DaemonConfig paced(v1::DaemonConfig c, double loop_rate_hz = 10'000) {
  c.mutable_controller()->set_pace_to_wall_clock(true);
  c.mutable_controller()->set_loop_rate_hz(loop_rate_hz);
  return c;
}

constexpr const char* kDwell = R"(
name: "dwell"
acquisition_rate_hz: 1000
segments { name: "approach" duration_s: 1 normal { end_uN: 0 } lateral { end_um: 4 } }
segments { name: "load" duration_s: 0.2 normal { end_uN: 1000 } lateral { shape: HOLD } }
segments { name: "dwell" duration_s: 30 normal { shape: HOLD } lateral { shape: HOLD } }
)";

void expect_latched_by_emergency_stop(InstrumentService& service) {
  const v1::StatusReply s = service.status();
  EXPECT_EQ(s.state(), v1::FAULTED);
  EXPECT_NE(s.trip_reason().find("emergency stop"), std::string::npos) << s.trip_reason();
  EXPECT_GE(service.last_emergency_stop_latency_s(), 0);
}

// Polls until the service reports the activity (no duration asserted).
void wait_for_activity(InstrumentService& service, const std::string& activity) {
  while (service.status().activity() != activity) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

TEST(EmergencyStop, DuringAPacedRunLatchesAndUnloads) {
  ServiceFixture f;
  f.config = paced(f.config);
  f.start();
  f.sink.at_time_s = 1.5;  // loaded, dwelling
  f.sink.at_time = [&] {
    v1::EmergencyStopReply r;
    f.service->emergency_stop("test: run", r);
    EXPECT_TRUE(r.run_was_active());
  };
  f.run(parse_protocol(kDwell));
  expect_latched_by_emergency_stop(*f.service);
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].exit_status(), v1::FAULT);
  EXPECT_NE(f.sink.stops[0].reason().find("test: run"), std::string::npos) << f.sink.stops[0].reason();
  // The safe stop sequence ran: the last samples are unloaded.
  const int n = sample_count(f.sink.samples);
  ASSERT_GT(n, 0);
  EXPECT_LT(std::fabs(f.sink.samples.normal_force_n(n - 1)), 50e-6);
}

TEST(EmergencyStop, DuringTheStopSequenceOfAnAbortLatches) {
  ServiceFixture f;
  f.config = paced(f.config);
  f.start();
  f.sink.at_time_s = 1.5;
  f.sink.at_time = [&] { ASSERT_FALSE(f.service->abort_run("test: abort")); };
  bool stopped = false;
  f.sink.on_event = [&](const v1::SegmentEvent& e) {
    if (e.kind() != v1::UNLOAD_BEGIN || stopped) return;
    stopped = true;
    v1::EmergencyStopReply r;
    f.service->emergency_stop("test: stop sequence", r);
  };
  f.run(parse_protocol(kDwell));
  ASSERT_TRUE(stopped) << "the abort's unload never began";
  expect_latched_by_emergency_stop(*f.service);
  ASSERT_EQ(f.sink.stops.size(), 1u);
  // Aborted, then the emergency stop during the unload: a FAULT, not an ABORT.
  EXPECT_EQ(f.sink.stops[0].exit_status(), v1::FAULT) << f.sink.stops[0].reason();
}

TEST(EmergencyStop, AfterTheRunsLastTickStillLatches) {
  // The run's last sample is published after the loop's last tick (the loop
  // checks nothing once it has pushed it): an emergency stop then reaches no
  // tick, while the run is finishing. It used to leave the daemon ARMED.
  ServiceFixture f;
  f.start();
  const v1::Protocol protocol = parse_protocol(R"(
    name: "short"
    acquisition_rate_hz: 1000
    segments { name: "approach" duration_s: 0.2 normal { end_uN: 0 } lateral { end_um: 1 } }
    segments { name: "return" duration_s: 0.2 normal { end_uN: 0 } lateral { end_um: 0 } }
  )");
  f.run(protocol);
  ASSERT_EQ(f.service->status().state(), v1::ARMED);
  const int n = sample_count(f.sink.samples);
  ASSERT_GT(n, 0);
  const double last_time_s = f.sink.samples.time_s(n - 1);
  f.sink.clear();
  f.sink.at_time_s = last_time_s;  // the block with the last sample (runs are bit-identical)
  f.sink.at_time = [&] {
    v1::EmergencyStopReply r;
    f.service->emergency_stop("test: late", r);
  };
  v1::StartRunReply started;
  ASSERT_FALSE(f.service->start_run(std::nullopt, started));
  f.service->wait_until_idle();
  ASSERT_TRUE(f.sink.acted);
  expect_latched_by_emergency_stop(*f.service);
  v1::StartRunReply again;
  EXPECT_TRUE(f.service->start_run(std::nullopt, again)) << "a run started after an emergency stop";
}

TEST(EmergencyStop, DuringAutotuneLatches) {
  ServiceFixture f;
  f.config = paced(f.config);
  f.start();
  std::promise<std::optional<v1::Error>> outcome;
  f.service->autotune_async(v1::Autotune{}, [&](std::optional<v1::Error> e, const v1::AutotuneReply&) {
    outcome.set_value(std::move(e));
  });
  wait_for_activity(*f.service, "autotune");
  v1::EmergencyStopReply r;
  ASSERT_FALSE(f.service->emergency_stop("test: autotune", r));
  EXPECT_TRUE(r.run_was_active());
  const auto error = outcome.get_future().get();
  ASSERT_TRUE(error);
  EXPECT_NE(error->message().find("emergency stop"), std::string::npos) << error->message();
  expect_latched_by_emergency_stop(*f.service);
}

TEST(EmergencyStop, DuringTheRearmCheckEndsItAndStaysLatched) {
  ServiceFixture f;
  // 100 Hz: the check's 64 ticks take 0.64 s paced, time enough for the
  // request to arrive during it.
  f.config = paced(f.config, 100);
  f.start();
  v1::EmergencyStopReply first;
  ASSERT_FALSE(f.service->emergency_stop("test: idle", first));
  ASSERT_EQ(f.service->status().state(), v1::FAULTED);
  // Blocking re-arm on another thread (as the API thread of old did).
  std::promise<std::optional<v1::Error>> outcome;
  std::thread rearming([&] {
    v1::RearmReply reply;
    outcome.set_value(f.service->rearm(reply));
  });
  wait_for_activity(*f.service, "re-arm check");
  v1::EmergencyStopReply during;
  ASSERT_FALSE(f.service->emergency_stop("test: re-arm", during));
  const auto error = outcome.get_future().get();
  rearming.join();
  ASSERT_TRUE(error) << "re-armed although an emergency stop arrived during the check";
  EXPECT_NE(error->message().find("emergency stop"), std::string::npos) << error->message();
  expect_latched_by_emergency_stop(*f.service);
  EXPECT_NE(f.service->status().trip_reason().find("test: re-arm"), std::string::npos);
}

TEST(EmergencyStop, WhileIdleUnloadsWhatTheLastRunLeftLoaded) {
  // The validator does not require a protocol to end unloaded: after this
  // SUCCESS run the backend still holds the last segment's 1 mN drive. An
  // emergency stop while ARMED used to latch FAULTED only, leaving the tip
  // loaded (the re-arm check then refused: "above the unloaded threshold").
  ServiceFixture f;
  f.start();
  f.run(parse_protocol(R"(
    name: "ends loaded"
    acquisition_rate_hz: 1000
    segments { name: "approach" duration_s: 0.2 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { name: "load" duration_s: 0.2 normal { end_uN: 1000 } lateral { shape: HOLD } }
    segments { name: "hold" duration_s: 0.1 normal { shape: HOLD } lateral { shape: HOLD } }
  )"));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  ASSERT_EQ(f.sink.stops[0].exit_status(), v1::SUCCESS) << f.sink.stops[0].reason();
  ASSERT_EQ(f.service->status().state(), v1::ARMED);
  const int n = sample_count(f.sink.samples);
  ASSERT_GT(n, 0);
  ASSERT_GT(f.sink.samples.normal_force_n(n - 1), 0.5e-3) << "the run did not end loaded";

  v1::EmergencyStopReply r;
  ASSERT_FALSE(f.service->emergency_stop("test: idle, loaded", r));
  expect_latched_by_emergency_stop(*f.service);  // at once: the reply does not wait for the unload
  f.service->wait_until_idle();                  // the stop sequence has ended
  expect_latched_by_emergency_stop(*f.service);
  // The re-arm check reads the continuing instrument: unloaded now.
  v1::RearmReply rearmed;
  const auto error = f.service->rearm(rearmed);
  ASSERT_FALSE(error) << error->message();
  EXPECT_LT(std::fabs(rearmed.normal_force_n()), f.config.supervisor().contact_force_n());
  EXPECT_LT(std::fabs(rearmed.normal_force_n()), 50e-6) << "not unloaded";
}

}  // namespace
}  // namespace tribo::daemon
