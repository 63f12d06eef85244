// The loop thread's real-time scheduling (an emergency stop acts within one
// loop period, which a loop at normal priority misses whenever the
// machine is busy). Whether SCHED_FIFO is granted depends on the machine
// (CAP_SYS_NICE, RLIMIT_RTPRIO): each test accepts either outcome but checks
// that what is reported is what is in force.
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>

#include <thread>

#include "daemon/daemon_config.h"
#include "daemon/loop_scheduling.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

struct Observed {
  LoopScheduling reported;
  int policy = -1;
  int priority = -1;
};

// On a fresh thread, so the test's own thread keeps its scheduling.
Observed apply_on_a_thread(int priority, bool paced) {
  Observed o;
  std::thread([&] {
    o.reported = apply_loop_scheduling(priority, paced);
    sched_param param{};
    pthread_getschedparam(pthread_self(), &o.policy, &param);
    o.priority = param.sched_priority;
  }).join();
  return o;
}

TEST(LoopScheduling, PriorityZeroKeepsNormalScheduling) {
  const Observed o = apply_on_a_thread(0, true);
  EXPECT_FALSE(o.reported.realtime);
  EXPECT_EQ(o.policy, SCHED_OTHER);
  EXPECT_NE(o.reported.description.find("loop_realtime_priority is 0"), std::string::npos);
}

TEST(LoopScheduling, AnUnpacedSimulatedLoopDoesNotAskForRealTime) {
  const Observed o = apply_on_a_thread(20, false);
  EXPECT_FALSE(o.reported.realtime);
  EXPECT_EQ(o.policy, SCHED_OTHER);
  EXPECT_NE(o.reported.description.find("unpaced"), std::string::npos);
}

TEST(LoopScheduling, APacedLoopReportsWhatIsInForce) {
  const Observed o = apply_on_a_thread(20, true);
  if (o.reported.realtime) {
    EXPECT_EQ(o.policy, SCHED_FIFO);
    EXPECT_EQ(o.priority, 20);
    EXPECT_EQ(o.reported.description, "SCHED_FIFO priority 20");
  } else {
    EXPECT_EQ(o.policy, SCHED_OTHER);
    EXPECT_NE(o.reported.description.find("refused"), std::string::npos) << o.reported.description;
  }
}

TEST(LoopScheduling, ThePriorityIsValidatedNamingTheField) {
  v1::DaemonConfig c = tribo::testing::default_config();
  for (int bad : {-1, 100}) {
    c.mutable_controller()->set_loop_realtime_priority(bad);
    const auto e = validate_daemon_config(c);
    ASSERT_TRUE(e) << bad;
    EXPECT_NE(e->find("controller.loop_realtime_priority"), std::string::npos) << *e;
  }
  c.mutable_controller()->set_loop_realtime_priority(99);
  EXPECT_FALSE(validate_daemon_config(c));
}

TEST(LoopScheduling, StatusSaysHowTheServicesLoopIsScheduled) {
  testing::ServiceFixture f;
  f.config.mutable_controller()->set_pace_to_wall_clock(true);
  f.config.mutable_controller()->set_loop_realtime_priority(20);
  f.start();
  const std::string s = f.service->status().loop_scheduling();
  EXPECT_TRUE(s == "SCHED_FIFO priority 20" || s.find("SCHED_FIFO priority 20 refused") != std::string::npos) << s;
}

TEST(LoopScheduling, StatusSaysNormalSchedulingForAnUnpacedSimulation) {
  testing::ServiceFixture f;
  f.config.mutable_controller()->set_pace_to_wall_clock(false);
  f.config.mutable_controller()->set_loop_realtime_priority(20);
  f.start();
  EXPECT_NE(f.service->status().loop_scheduling().find("unpaced"), std::string::npos);
}

}  // namespace
}  // namespace tribo::daemon
