// Fault injection in the simulated backend (sim/fault_injection.h), seen
// through the Transducer interface as the controller sees it.
#include "sim/fault_injection.h"

#include <gtest/gtest.h>

#include <cmath>

#include "hal/sim_transducer.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::sim {
namespace {

constexpr double kDt = 1e-4;

FaultSpec fault(FaultKind kind, FaultChannel channel, double start, double duration, double value = 0) {
  FaultSpec f;
  f.kind = kind;
  f.channel = channel;
  f.start_s = start;
  f.duration_s = duration;
  f.value = value;
  return f;
}

hal::SimTransducer transducer(std::vector<FaultSpec> faults, std::uint64_t seed = 1) {
  const v1::DaemonConfig c = testing::default_config();
  return hal::SimTransducer(instrument_params_from_config(c.sim()), seed, 1e4, false, std::move(faults));
}

// Drives both transducers with the same constant drive for n ticks and
// returns the readings (tick k is read at t = k dt).
std::vector<hal::SensorFrame> readings(hal::SimTransducer& t, int n, hal::DriveCommand drive = {1e-3, 300e-6}) {
  std::vector<hal::SensorFrame> out;
  for (int k = 0; k < n; ++k) {
    hal::SensorFrame f;
    f.lateral_position_m = -1;  // marks "not updated"
    t.read(f);
    out.push_back(f);
    t.write(drive);
    t.wait_next_tick();
  }
  return out;
}

TEST(FaultInjection, WithoutFaultsTheReadingsAreThoseOfThePlainBackend) {
  auto plain = transducer({});
  auto faulted = transducer({fault(FaultKind::kSensorOffset, FaultChannel::kNormalForce, 1.0, 0.1, 1e-3)});
  const auto a = readings(plain, 500), b = readings(faulted, 500);
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(a[k].lateral_position_m, b[k].lateral_position_m) << k;
    ASSERT_EQ(a[k].normal_force_n, b[k].normal_force_n) << k;
  }
}

TEST(FaultInjection, SensorFaultsActOnTheirChannelInTheirWindowOnly) {
  auto plain = transducer({});
  auto t = transducer({fault(FaultKind::kSensorDropout, FaultChannel::kNormalForce, 0.01, 0.005),
                       fault(FaultKind::kSensorNan, FaultChannel::kLateralForce, 0.02, 0.001),
                       fault(FaultKind::kSensorOffset, FaultChannel::kNormalDisplacement, 0.03, 0.002, 5e-6),
                       fault(FaultKind::kSensorFreeze, FaultChannel::kLateralPosition, 0.04, 0.003)});
  const auto a = readings(plain, 500), b = readings(t, 500);
  for (int k = 0; k < 500; ++k) {
    const bool dropout = k >= 100 && k < 150, nan = k >= 200 && k < 210, offset = k >= 300 && k < 320,
               frozen = k >= 400 && k < 430;
    EXPECT_EQ(b[k].normal_force_n, dropout ? 0.0 : a[k].normal_force_n) << k;
    EXPECT_EQ(std::isnan(b[k].lateral_force_n), nan) << k;
    if (!nan) {
      EXPECT_EQ(b[k].lateral_force_n, a[k].lateral_force_n) << k;
    }
    EXPECT_DOUBLE_EQ(b[k].normal_displacement_m, a[k].normal_displacement_m + (offset ? 5e-6 : 0)) << k;
    EXPECT_EQ(b[k].lateral_position_m, frozen ? a[399].lateral_position_m : a[k].lateral_position_m) << k;
  }
  // The plant itself moved on while its reading was frozen.
  EXPECT_NE(a[429].lateral_position_m, a[399].lateral_position_m);
}

TEST(FaultInjection, NoiseBurstsAreSeededAndReproducible) {
  const auto burst = [](std::uint64_t seed) {
    auto t = transducer({fault(FaultKind::kNoiseBurst, FaultChannel::kLateralForce, 0, 0, 50e-6)}, seed);
    return readings(t, 2000);
  };
  auto plain = transducer({});
  const auto a = burst(5), b = burst(5), c = burst(6), quiet = readings(plain, 2000);
  double sum_sq = 0;
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(a[k].lateral_force_n, b[k].lateral_force_n);
    const double extra = a[k].lateral_force_n - quiet[k].lateral_force_n;
    sum_sq += extra * extra;
  }
  EXPECT_NE(a[1000].lateral_force_n, c[1000].lateral_force_n);
  // Seed 5's plant noise differs from seed 1's, so compare RMS loosely:
  // sqrt(50^2 + 2 x 10^2) µN.
  EXPECT_NEAR(std::sqrt(sum_sq / 2000), 52e-6, 5e-6);
}

TEST(FaultInjection, AStuckActuatorHoldsWhatThePlantFeels) {
  FaultSpec stuck = fault(FaultKind::kActuatorStuck, FaultChannel::kLateralActuator, 0.01, 0.0, 0);
  auto t = transducer({stuck});
  readings(t, 100, {0, 300e-6});  // drive 300 µN until the fault starts
  // Commands of -1 mN are ignored: the tip rings down (tau = 2m/c = 0.25 s)
  // to 300 µN on the 116 N/m spring.
  readings(t, 15000, {0, -1e-3});
  EXPECT_NEAR(t.instrument().truth().lateral.position_m, 300e-6 / 116, 0.02e-6);
}

TEST(FaultInjection, LinkLossAndTimeoutsFailTheIo) {
  auto t = transducer({fault(FaultKind::kLinkDown, FaultChannel::kNone, 0.001, 0.001),
                       fault(FaultKind::kReadTimeout, FaultChannel::kNone, 0.003, 0.0005),
                       fault(FaultKind::kLoopOverrun, FaultChannel::kNone, 0.004, 0.0003)});
  std::vector<hal::IoResult> reads, writes;
  for (int k = 0; k < 60; ++k) {
    hal::SensorFrame f;
    reads.push_back(t.read(f));
    writes.push_back(t.write({0, 1e-6 * k}));
    t.wait_next_tick();
  }
  for (int k = 0; k < 60; ++k) {
    const bool down = k >= 10 && k < 20, timeout = k >= 30 && k < 35;
    EXPECT_EQ(reads[k], down ? hal::IoResult::kLinkDown : timeout ? hal::IoResult::kTimeout : hal::IoResult::kOk) << k;
    EXPECT_EQ(writes[k], down ? hal::IoResult::kLinkDown : hal::IoResult::kOk) << k;
  }
  EXPECT_EQ(t.overruns(), 3u);
}

TEST(FaultInjection, SchedulesAreValidatedWithTheFieldNamed) {
  v1::FaultSchedule s;
  v1::InjectedFault* f = s.add_faults();
  f->set_kind(v1::SENSOR_NAN);
  f->set_channel(v1::CHANNEL_LATERAL_ACTUATOR);
  auto e = validate_fault_schedule(s);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("sim.faults.faults[0].channel"), std::string::npos) << *e;
  f->set_channel(v1::CHANNEL_LATERAL_POSITION);
  f->set_start_s(-1);
  e = validate_fault_schedule(s);
  ASSERT_TRUE(e);
  EXPECT_NE(e->find("faults[0].start_s = -1"), std::string::npos) << *e;
  f->set_start_s(1);
  EXPECT_FALSE(validate_fault_schedule(s));
}

}  // namespace
}  // namespace tribo::sim
