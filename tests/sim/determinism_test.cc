// Determinism of the simulated instrument: the same binary, config, protocol
// and seed give the same samples, bit for bit, through the daemon's own loop
// (as tribod and tribo_native.simulate run it) -- on every named config, a
// break-away protocol and a scratch, with sensor noise and injected faults
// (a noise burst, a sensor offset, a read timeout). Another seed gives other
// samples. Across code changes the physics is pinned by tolerances instead
// (tests/sim/fine_step_reference_test.cc, the integrator's convergence and
// energy tests, the scorecard's seed band), not by stored bits.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <string>

#include "tests/sim/protocol_run.h"

namespace tribo::testing {
namespace {

// Break-away from rest twice (after 0.3 s and 1 s of dwell), both directions.
constexpr const char* kStopStart = R"pb(
  name: "stop-start"
  acquisition_rate_hz: 10000
  segments { name: "approach" duration_s: 0.3 normal { end_uN: 0 } lateral { end_um: 2 } }
  segments { name: "load" duration_s: 1 normal { end_uN: 1000 } lateral { shape: HOLD } }
  segments { name: "dwell" duration_s: 0.3 normal { shape: HOLD } lateral { shape: HOLD } }
  segments { name: "slide" normal { shape: HOLD } lateral { delta_um: 1 speed_um_per_s: 2 } }
  segments { name: "dwell" duration_s: 1 normal { shape: HOLD } lateral { shape: HOLD } }
  segments { name: "back" normal { shape: HOLD } lateral { delta_um: -1 speed_um_per_s: 2 } }
  segments { name: "unload" duration_s: 0.5 normal { end_uN: 0 } lateral { shape: HOLD } }
)pb";

// A scratch at a lighter load, out and back, then lift-off.
constexpr const char* kScratch = R"pb(
  name: "scratch"
  acquisition_rate_hz: 10000
  segments { name: "approach" duration_s: 0.3 normal { end_uN: 0 } lateral { end_um: 1 } }
  segments { name: "load" duration_s: 0.7 normal { end_uN: 500 } lateral { end_um: 1 } }
  segments { name: "scratch" duration_s: 1.5 normal { end_uN: 500 } lateral { end_um: 4 } }
  segments { name: "back" duration_s: 1 normal { end_uN: 500 } lateral { end_um: 2 } }
  segments { name: "unload" duration_s: 0.5 normal { end_uN: 0 } lateral { end_um: 2 } }
)pb";

void add_fault(v1::DaemonConfig& config, v1::FaultKind kind, v1::FaultChannel channel, double start_s,
               double duration_s, double value) {
  v1::InjectedFault* f = config.mutable_sim()->mutable_faults()->add_faults();
  f->set_kind(kind);
  f->set_channel(channel);
  f->set_start_s(start_s);
  f->set_duration_s(duration_s);
  f->set_value(value);
}

v1::DaemonConfig with_faults(const std::string& relative_path) {
  v1::DaemonConfig config = config_file(relative_path);
  add_fault(config, v1::NOISE_BURST, v1::CHANNEL_LATERAL_FORCE, 1.5, 0.4, 2e-6);
  add_fault(config, v1::SENSOR_OFFSET, v1::CHANNEL_NORMAL_DISPLACEMENT, 2.0, 0.3, 1e-9);
  add_fault(config, v1::READ_TIMEOUT, v1::FAULT_CHANNEL_UNSPECIFIED, 2.5, 0.0005, 0);
  return config;
}

// Every channel's bits (a NaN of a failed read compares by its bits too).
bool same_bits(const Sample& a, const Sample& b) {
  for (auto field : {&Sample::time_s, &Sample::normal_setpoint_n, &Sample::normal_force_n,
                     &Sample::normal_displacement_m, &Sample::lateral_setpoint_m, &Sample::lateral_position_m,
                     &Sample::lateral_force_n}) {
    if (std::bit_cast<std::uint64_t>(a.*field) != std::bit_cast<std::uint64_t>(b.*field)) return false;
  }
  return a.segment_index == b.segment_index && a.status_flags == b.status_flags;
}

struct Case {
  const char* config;
  const char* protocol_name;
  const char* protocol;
};

class Determinism : public ::testing::TestWithParam<Case> {};

TEST_P(Determinism, SameSeedSameBitsAnotherSeedOtherSamples) {
  const Case& c = GetParam();
  const v1::DaemonConfig config = with_faults(c.config);
  const ProtocolRun a = run_protocol(config, protocol_text(c.protocol), 7);
  const ProtocolRun b = run_protocol(config, protocol_text(c.protocol), 7);
  const ProtocolRun other = run_protocol(config, protocol_text(c.protocol), 8);
  ASSERT_EQ(a.end, daemon::RunEnd::kCompleted) << "the run must cover the whole protocol";
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    ASSERT_TRUE(same_bits(a.samples[k], b.samples[k])) << c.config << " / " << c.protocol_name << ", sample " << k;
    ASSERT_EQ(std::bit_cast<std::uint64_t>(a.friction_n[k]), std::bit_cast<std::uint64_t>(b.friction_n[k]));
  }
  ASSERT_EQ(a.samples.size(), other.samples.size());
  std::size_t differing = 0;
  for (std::size_t k = 0; k < a.samples.size(); ++k) differing += !same_bits(a.samples[k], other.samples[k]);
  EXPECT_GT(differing, a.samples.size() / 2) << "another seed should give other noise";
}

INSTANTIATE_TEST_SUITE_P(
    NamedConfigs, Determinism,
    ::testing::Values(Case{"config/tribod.textproto", "stop_start", kStopStart},
                      Case{"config/tribod.textproto", "scratch", kScratch},
                      Case{"config/instruments/lugre_plain.textproto", "stop_start", kStopStart},
                      Case{"config/instruments/lugre_plain.textproto", "scratch", kScratch},
                      Case{"config/instruments/appendix_c.textproto", "stop_start", kStopStart},
                      Case{"config/instruments/appendix_c.textproto", "scratch", kScratch},
                      // the slip-rate contact: S solved from a guess carried across ticks
                      Case{"config/instruments/slip_rate_contact/all.textproto", "stop_start", kStopStart},
                      Case{"config/instruments/slip_rate_contact/all.textproto", "scratch", kScratch}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string name = std::string(info.param.config);
      name = name.substr(name.rfind('/') + 1);
      name = name.substr(0, name.find('.'));
      return name + "_" + info.param.protocol_name;
    });

}  // namespace
}  // namespace tribo::testing
