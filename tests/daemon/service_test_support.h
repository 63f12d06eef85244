// Shared set-up for daemon tests that run protocols through the
// InstrumentService on the simulated instrument: a sink that collects the run
// documents (and can act at a given run time), a fixture, protocol files and
// the check of the safe stop sequence.
#pragma once

#include <gtest/gtest.h>

#include <google/protobuf/text_format.h>

#include <cmath>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "daemon/instrument_service.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
#include "hal/backend_factory.h"
#include "proto/sample_record.h"
#include "tests/support/safe_sequence.h"
#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::daemon::testing {

// Collects run documents; calls `at_time` once when a block reaches at_time_s.
class RecordingSink : public RunEventSink {
 public:
  void on_run_start(const v1::RunStart& start) override {
    std::lock_guard lock(mutex_);
    starts.push_back(start);
  }
  void on_samples(const v1::SampleBlock& block) override {
    std::function<void()> action;
    {
      std::lock_guard lock(mutex_);
      if (static_cast<std::uint64_t>(sample_count(samples)) != block.first_sequence()) gaps = true;
      append_block(block, samples);
      if (at_time && !acted && block.time_s(block.time_s_size() - 1) >= at_time_s) {
        acted = true;
        action = at_time;
      }
    }
    if (action) action();
  }
  void on_run_stop(const v1::RunStop& stop) override {
    std::lock_guard lock(mutex_);
    stops.push_back(stop);
  }
  void on_segment_event(const v1::SegmentEvent& event) override {
    {
      std::lock_guard lock(mutex_);
      events.push_back(event);
    }
    if (on_event) on_event(event);
  }
  void clear() {
    std::lock_guard lock(mutex_);
    starts.clear();
    stops.clear();
    events.clear();
    samples.Clear();
    acted = false;
  }

  std::vector<v1::RunStart> starts;
  v1::SampleBlock samples;
  std::vector<v1::RunStop> stops;
  std::vector<v1::SegmentEvent> events;
  bool gaps = false;
  double at_time_s = 0;
  std::function<void()> at_time;
  bool acted = false;
  // Called (on the service's drain thread) after each segment event.
  std::function<void(const v1::SegmentEvent&)> on_event;

 private:
  std::mutex mutex_;
};

inline v1::Protocol load_protocol_file(const std::string& name) {
  v1::Protocol p;
  if (auto e = wire::load_text_proto_file(std::string(TRIBO_SOURCE_DIR) + "/config/protocols/" + name, p)) {
    throw std::runtime_error(*e);
  }
  return p;
}

inline v1::Protocol parse_protocol(const std::string& text) {
  v1::Protocol p;
  if (!google::protobuf::TextFormat::ParseFromString(text, &p)) throw std::runtime_error("bad protocol text");
  return p;
}

struct ServiceFixture {
  tribo::testing::TempDir dir;
  v1::DaemonConfig config = tribo::testing::default_config();
  RecordingSink sink;
  std::unique_ptr<InstrumentService> service;

  ServiceFixture() { config.mutable_recorder()->set_data_dir(dir.path().string()); }
  void start() { service = std::make_unique<InstrumentService>(config, "test", sink); }
  // Loads, starts and waits for the end of the run.
  void run(const v1::Protocol& protocol) {
    v1::LoadProtocolReply loaded;
    const auto load_error = service->load_protocol(protocol, loaded);
    ASSERT_FALSE(load_error) << load_error->message();
    v1::StartRunReply started;
    const auto start_error = service->start_run(std::nullopt, started);
    ASSERT_FALSE(start_error) << start_error->message();
    service->wait_until_idle();
  }
  v1::InjectedFault& add_fault(v1::FaultKind kind, v1::FaultChannel channel, double start_s, double duration_s,
                       double value = 0) {
    v1::InjectedFault& f = *config.mutable_sim()->mutable_faults()->add_faults();
    f.set_kind(kind);
    f.set_channel(channel);
    f.set_start_s(start_s);
    f.set_duration_s(duration_s);
    f.set_value(value);
    return f;
  }
};

// Runs a protocol through the real-time loop on this thread (no service, no
// recording): every recorded sample and every tick's drive. before_tick is
// called before each tick with its number.
struct LoopRun {
  std::vector<Sample> samples;
  std::vector<hal::DriveCommand> drives;
  RunOutcome outcome;
};

inline LoopRun run_in_loop(const v1::DaemonConfig& config, const v1::Protocol& protocol,
                           const std::function<void(std::uint64_t, RunControl&)>& before_tick = {},
                           std::uint64_t seed = 1) {
  const ProtocolCheck check = validate_protocol(protocol, config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().message);
  auto transducer = hal::make_transducer(config, seed);
  SpscQueue<Sample> queue(1 << 21);
  RunControl control;
  RunTelemetry telemetry;
  RunLoopConfig loop_config = run_loop_config_from(config);
  RunLoop loop(*transducer, check.load_function, loop_config, queue, control, telemetry);
  LoopRun run;
  for (std::uint64_t tick = 0;; ++tick) {
    if (before_tick) before_tick(tick, control);
    if (!loop.tick()) break;
    run.drives.push_back(loop.controller().last_drive());
  }
  run.outcome = loop.outcome();
  Sample sample;
  while (queue.try_pop(sample)) run.samples.push_back(sample);
  return run;
}

// Mean of a channel over the samples with t in [from, to).
inline double mean_between(const std::vector<Sample>& samples, double from, double to,
                           double Sample::*channel) {
  double sum = 0;
  int n = 0;
  for (const Sample& s : samples) {
    if (s.time_s >= from && s.time_s < to) {
      sum += s.*channel;
      ++n;
    }
  }
  return n > 0 ? sum / n : std::nan("");
}

// The safe stop sequence checks, shared with the Modbus tests.
using tribo::testing::expect_safe_sequence;
using tribo::testing::first_sample_with;

}  // namespace tribo::daemon::testing
