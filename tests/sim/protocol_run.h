// A protocol run through the daemon's own real-time loop (daemon/run_loop.h,
// unpaced, as tribo_native.simulate and tribod run it), recorded at every
// tick, with the simulated plant's true state beside the record: for the
// tests of the simulator's numerics (determinism, accuracy against a
// fine-step reference).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "hal/backend_factory.h"
#include "hal/sim_transducer.h"
#include "proto/text_format_file.h"

namespace tribo::testing {

struct ProtocolRun {
  std::vector<Sample> samples;             // one per tick
  std::vector<double> friction_n;          // the plant's true friction after each tick
  std::vector<double> position_m;          // the plate's true position after each tick
  long ticks = 0;
  long law_evaluations = 0;                // of S, by the held-contact scheme
  daemon::RunEnd end = daemon::RunEnd::kCompleted;
};

inline v1::DaemonConfig config_file(const std::string& relative_path) {
  v1::DaemonConfig config;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/" + relative_path;
  if (auto error = daemon::load_daemon_config(path, config)) throw std::runtime_error(*error);
  return config;
}

inline v1::Protocol protocol_text(const std::string& text) {
  v1::Protocol protocol;
  if (auto error = wire::parse_text_proto(text, "protocol", protocol)) throw std::runtime_error(*error);
  return protocol;
}

inline v1::Protocol protocol_file(const std::string& relative_path) {
  v1::Protocol protocol;
  const std::string path = std::string(TRIBO_SOURCE_DIR) + "/" + relative_path;
  if (auto error = wire::load_text_proto_file(path, protocol)) throw std::runtime_error(*error);
  return protocol;
}

// Every tick recorded (the protocol's acquisition rate is set to the loop rate).
inline ProtocolRun run_protocol(const v1::DaemonConfig& config, v1::Protocol protocol, std::uint64_t seed) {
  protocol.set_acquisition_rate_hz(config.controller().loop_rate_hz());
  const daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  auto transducer = hal::make_transducer(config, seed);
  const auto& sim = dynamic_cast<const hal::SimTransducer&>(*transducer);
  daemon::SpscQueue<Sample> queue(1 << 12);
  daemon::RunControl control;
  daemon::RunTelemetry telemetry;
  daemon::RunLoop loop(*transducer, check.load_function, daemon::run_loop_config_from(config), queue, control,
                       telemetry);
  ProtocolRun run;
  Sample sample;
  auto drain = [&] {
    while (queue.try_pop(sample)) run.samples.push_back(sample);
  };
  for (bool more = true; more;) {
    more = loop.tick();
    const sim::InstrumentTruth& truth = sim.instrument().truth();
    run.friction_n.push_back(truth.friction_n);
    run.position_m.push_back(truth.lateral.position_m);
    run.law_evaluations += sim.last_report().law_evaluations;
    ++run.ticks;
    drain();
  }
  drain();
  run.end = loop.outcome().end;
  return run;
}

}  // namespace tribo::testing
