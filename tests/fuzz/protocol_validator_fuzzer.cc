// libFuzzer target: the protocol validator (daemon/protocol_validator.h) on
// protocols from the wire. Input: a tribo.v1.Protocol, binary, or text format
// when it starts with '#'. Limits: the repository's config/tribod.textproto.
// Checked: an accepted protocol compiles to a load function whose setpoints
// are finite and within the instrument's force and travel limits, whose
// duration is within the protocol limit, and whose segments tile its ticks.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include <google/protobuf/stubs/logging.h>

#include "daemon/protocol_validator.h"
#include "proto/text_format_file.h"
#include "tribo/v1/daemon_config.pb.h"

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

const tribo::v1::DaemonConfig& config() {
  static const tribo::v1::DaemonConfig c = [] {
    google::protobuf::SetLogHandler(nullptr);  // invalid UTF-8 in strings is expected here
    tribo::v1::DaemonConfig loaded;
    if (tribo::wire::load_text_proto_file(TRIBO_SOURCE_DIR "/config/tribod.textproto", loaded)) std::abort();
    return loaded;
  }();
  return c;
}

bool within(double value, double limit) { return std::isfinite(value) && std::fabs(value) <= limit * (1 + 1e-9); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  tribo::v1::Protocol protocol;
  if (!input.empty() && input[0] == '#') {
    if (tribo::wire::parse_text_proto(input, "fuzz", protocol)) return 0;
  } else if (!protocol.ParseFromString(input)) {
    return 0;
  }
  const auto& limits = config().limits();
  const tribo::daemon::ProtocolCheck result = tribo::daemon::validate_protocol(protocol, config());
  for (const auto& e : result.errors) check(!e.message.empty());
  if (!result.ok()) return 0;

  const auto& lf = result.load_function;
  check(lf.total_ticks() > 0);
  check(static_cast<double>(lf.total_ticks()) / lf.loop_rate_hz() <= limits.max_protocol_duration_s() * (1 + 1e-9));
  std::uint64_t next_tick = 0;
  for (const auto& s : lf.segments()) {
    check(s.start_tick == next_tick);
    next_tick += s.tick_count;
    check(s.ticks_per_sample >= 1);
  }
  // The setpoints at every segment's first and last tick, from an instrument
  // at rest: finite, and within the force and travel limits of their mode.
  tribo::daemon::SegmentRunner runner(lf);
  const tribo::daemon::MeasuredStart at_rest;
  for (const auto& s : lf.segments()) {
    for (const std::uint64_t tick : {s.start_tick, s.start_tick + s.tick_count - 1}) {
      const tribo::daemon::TickSetpoints sp = runner.at(tick, at_rest);
      const bool normal_force = sp.normal_mode != tribo::daemon::NormalMode::kDisplacement;
      check(within(sp.normal, normal_force ? limits.max_normal_force_n() : limits.max_normal_travel_m()));
      const bool lateral_force = sp.lateral_mode == tribo::daemon::LateralMode::kForce;
      check(within(sp.lateral, lateral_force ? limits.max_lateral_force_n() : limits.max_lateral_travel_m()));
    }
  }
  check(next_tick == lf.total_ticks());
  return 0;
}
