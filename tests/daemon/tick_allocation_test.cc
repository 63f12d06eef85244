// The real-time tick allocates nothing: this test binary replaces the global
// operator new and counts the allocations made while RunLoop::tick() runs —
// control, supervision, a safety trip, the stop sequence, gain changes, the
// simulated plant and its fault injection included, with the friction
// compensation off and on (its observer, its velocity delay, its switch-off at the trip).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "tests/daemon/service_test_support.h"

namespace {

std::atomic<bool> counting{false};
std::atomic<std::uint64_t> allocations{0};

void* allocate(std::size_t size) {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace tribo::daemon {
namespace {

TEST(TickAllocation, TheTickPathAllocatesNothing) {
  v1::DaemonConfig config = tribo::testing::default_config();
  // A noise burst and a frozen readout: the supervisor trips at about 13 s
  // and the stop sequence runs to its end.
  auto& faults = *config.mutable_sim()->mutable_faults();
  v1::InjectedFault* burst = faults.add_faults();
  burst->set_kind(v1::NOISE_BURST);
  burst->set_channel(v1::CHANNEL_NORMAL_FORCE);
  burst->set_start_s(10);
  burst->set_duration_s(0.5);
  burst->set_value(1e-6);
  for (const auto channel : {v1::CHANNEL_LATERAL_POSITION, v1::CHANNEL_LATERAL_FORCE, v1::CHANNEL_NORMAL_FORCE,
                             v1::CHANNEL_NORMAL_DISPLACEMENT}) {
    v1::InjectedFault* freeze = faults.add_faults();
    freeze->set_kind(v1::SENSOR_FREEZE);
    freeze->set_channel(channel);
    freeze->set_start_s(13);
    freeze->set_duration_s(0.1);
  }
  v1::Protocol protocol = testing::load_protocol_file("standard_scratch.textproto");
  // Off; on; on with the observer's velocity delayed by the loop's lag (its
  // delay line is allocated with the controller, before the ticks).
  for (const int pass : {0, 1, 2}) {
    const bool compensated = pass > 0;
    if (pass == 2) {
      config.mutable_controller()->mutable_friction_compensation()->set_velocity_delay_s(0.0753);
      config.mutable_controller()->mutable_friction_compensation()->set_velocity_lag_s(0.0753);
      config.mutable_controller()->mutable_friction_compensation()->set_velocity_filter_hz(50);
      config.mutable_controller()->mutable_friction_compensation()->set_contact_state_from_measured_velocity(true);
    }
    if (compensated) {
      const auto report = wire::read_file(std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/identification.json");
      ASSERT_TRUE(report);
      protocol.mutable_friction_compensation()->set_report_json(*report);
    }
    const ProtocolCheck check = validate_protocol(protocol, config);
    ASSERT_TRUE(check.ok());
    ASSERT_EQ(check.load_function.friction_models().size(), compensated ? 1u : 0u);
    auto transducer = hal::make_transducer(config, 3);
    SpscQueue<Sample> queue(1 << 16);
    RunControl control;
    RunTelemetry telemetry;
    RunLoop loop(*transducer, check.load_function, run_loop_config_from(config), queue, control, telemetry);
    PidGains stiffer = pid_gains_from_proto(config.controller().lateral_displacement());
    stiffer.kp = 2000;

    std::uint64_t ticks = 0, counted = 0;
    Sample drained;
    for (;; ++ticks) {
      if (ticks == 120000) control.gain_updates.try_push({Loop::kLateralDisplacement, stiffer});
      counting.store(true);
      const bool more = loop.tick();
      counting.store(false);
      counted += allocations.exchange(0);
      if (!more) break;
      while (queue.try_pop(drained)) {
      }
    }
    EXPECT_EQ(counted, 0u) << "allocations during " << ticks << " ticks" << (compensated ? ", compensated" : "")
                             << (pass == 2 ? ", velocity delayed and lagged" : "");
    EXPECT_EQ(loop.outcome().end, RunEnd::kTripped) << "the trip and the stop sequence ran";
    EXPECT_GT(ticks, 130000u);
  }

  // The counter works: an allocation while counting is seen.
  counting.store(true);
  auto* probe = new double(1);
  counting.store(false);
  delete probe;
  EXPECT_EQ(allocations.exchange(0), 1u);
}

}  // namespace
}  // namespace tribo::daemon
