// Pins the exact samples of the simulated instrument (issue 17: a faster sim
// must stay bit-identical). Each named instrument config runs a short
// stop-start (break-away) protocol and a short scratch through the daemon's
// own loop (daemon/run_loop.h, unpaced, as tribo_native.simulate and tribod
// run it), recorded at every tick, with its sensor noise and with injected
// faults (a noise burst, a sensor offset, a read timeout); an FNV-1a hash over
// the raw bits of every channel of every sample must equal the value computed
// on the code before the speed work (main at 64008b3). Any change of a
// floating-point operation in the plant, the sensors or the controller moves
// the hash. The configs are named files, never "the default": the default
// changes, the pinned files do not (the default of main at 64008b3 is frozen
// in tests/data/sample_pin/tribod_64008b3.textproto).
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "hal/backend_factory.h"
#include "proto/text_format_file.h"

namespace tribo {
namespace {

// Break-away from rest twice (after 0.3 s and 1 s of dwell), both directions.
constexpr const char* kStopStart = R"pb(
  name: "pin-stop-start"
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
  name: "pin-scratch"
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

v1::DaemonConfig named_config(const std::string& relative_path) {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/" + relative_path;
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  add_fault(config, v1::NOISE_BURST, v1::CHANNEL_LATERAL_FORCE, 1.5, 0.4, 2e-6);
  add_fault(config, v1::SENSOR_OFFSET, v1::CHANNEL_NORMAL_DISPLACEMENT, 2.0, 0.3, 1e-9);
  add_fault(config, v1::READ_TIMEOUT, v1::FAULT_CHANNEL_UNSPECIFIED, 2.5, 0.0005, 0);
  return config;
}

std::uint64_t fnv1a(std::uint64_t hash, std::uint64_t word) {
  for (int i = 0; i < 8; ++i) {
    hash ^= (word >> (8 * i)) & 0xff;
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

struct PinnedRun {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  std::size_t samples = 0;
  daemon::RunEnd end = daemon::RunEnd::kCompleted;
};

// The run as tribo_native.simulate runs it (client/python/native/tribo_native.cc).
PinnedRun run_pinned(const v1::DaemonConfig& config, const char* protocol_text, std::uint64_t seed) {
  v1::Protocol protocol;
  if (auto error = wire::parse_text_proto(protocol_text, "protocol", protocol)) throw std::runtime_error(*error);
  const daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  auto transducer = hal::make_transducer(config, seed);
  daemon::SpscQueue<Sample> queue(1 << 12);
  daemon::RunControl control;
  daemon::RunTelemetry telemetry;
  daemon::RunLoop loop(*transducer, check.load_function, daemon::run_loop_config_from(config), queue, control,
                       telemetry);
  PinnedRun run;
  auto take = [&](const Sample& s) {
    for (double v : {s.time_s, s.normal_setpoint_n, s.normal_force_n, s.normal_displacement_m,
                     s.lateral_setpoint_m, s.lateral_position_m, s.lateral_force_n}) {
      run.hash = fnv1a(run.hash, std::bit_cast<std::uint64_t>(v));
    }
    run.hash = fnv1a(run.hash, (static_cast<std::uint64_t>(s.segment_index) << 32) | s.status_flags);
    ++run.samples;
  };
  Sample sample;
  while (loop.tick()) {
    while (queue.try_pop(sample)) take(sample);
  }
  while (queue.try_pop(sample)) take(sample);
  run.end = loop.outcome().end;
  return run;
}

struct Pin {
  const char* config;
  const char* protocol_name;
  const char* protocol;
  std::uint64_t hash;
  std::size_t samples;
};

class SamplePin : public ::testing::TestWithParam<Pin> {};

TEST_P(SamplePin, SamplesAreBitIdenticalToThePinnedRun) {
  const Pin& pin = GetParam();
  const PinnedRun run = run_pinned(named_config(pin.config), pin.protocol, 7);
  EXPECT_EQ(run.end, daemon::RunEnd::kCompleted) << "the pinned run must cover the whole protocol";
  EXPECT_EQ(run.samples, pin.samples);
  EXPECT_EQ(run.hash, pin.hash) << pin.config << " / " << pin.protocol_name << ": 0x" << std::hex << run.hash;
}

// Computed on main at 64008b3, before the speed work of issue 17; those of
// dissertation_fit again after issue 14's speed work (2026-11-26), which
// changed the rounding of its contact law (the elasto-plastic blend, the
// rate-and-state terms; docs/physics_and_sources.md, "Numerics") and
// nothing else: the plain LuGre plant and the frozen default keep theirs.
INSTANTIATE_TEST_SUITE_P(
    NamedConfigs, SamplePin,
    ::testing::Values(
        Pin{"tests/data/sample_pin/tribod_64008b3.textproto", "stop_start", kStopStart, 0xb9d85adde8ff3970ULL, 41000},
        Pin{"tests/data/sample_pin/tribod_64008b3.textproto", "scratch", kScratch, 0x387e758942eeb47aULL, 40000},
        Pin{"config/instruments/lugre_plain.textproto", "stop_start", kStopStart, 0x69f2a703601eecd7ULL, 41000},
        Pin{"config/instruments/lugre_plain.textproto", "scratch", kScratch, 0x30cde30c9f50f546ULL, 40000},
        Pin{"config/instruments/dissertation_fit.textproto", "stop_start", kStopStart, 0x1f499585232bfc80ULL, 41000},
        Pin{"config/instruments/dissertation_fit.textproto", "scratch", kScratch, 0x53c22d1ad1fb70b2ULL, 40000},
        Pin{"config/instruments/appendix_c.textproto", "stop_start", kStopStart, 0x4597bb3b417b9102ULL, 41000},
        Pin{"config/instruments/appendix_c.textproto", "scratch", kScratch, 0x7883bfc94f710e03ULL, 40000}));

}  // namespace
}  // namespace tribo
