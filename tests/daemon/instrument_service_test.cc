#include "daemon/instrument_service.h"

#include <gtest/gtest.h>

#include <mutex>

#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::daemon {
namespace {

// Collects run documents; can ask the service to abort once a time is reached.
class RecordingSink : public RunEventSink {
 public:
  void on_run_start(const v1::RunStart& start) override {
    std::lock_guard lock(mutex_);
    starts.push_back(start);
  }
  void on_samples(const v1::SampleBlock& block) override {
    std::lock_guard lock(mutex_);
    if (static_cast<std::uint64_t>(sample_count(samples)) != block.first_sequence()) gaps = true;
    append_block(block, samples);
    if (abort_at_s > 0 && !abort_sent && block.time_s(block.time_s_size() - 1) >= abort_at_s) {
      abort_sent = true;
      service->abort_run("test abort");
    }
  }
  void on_run_stop(const v1::RunStop& stop) override {
    std::lock_guard lock(mutex_);
    stops.push_back(stop);
  }

  std::vector<v1::RunStart> starts;
  v1::SampleBlock samples;
  std::vector<v1::RunStop> stops;
  bool gaps = false;
  double abort_at_s = 0;
  bool abort_sent = false;
  InstrumentService* service = nullptr;

 private:
  std::mutex mutex_;
};

v1::Protocol standard_protocol() {
  v1::Protocol p;
  if (auto e = wire::load_text_proto_file(
          std::string(TRIBO_SOURCE_DIR) + "/config/protocols/standard_scratch.textproto", p)) {
    throw std::runtime_error(*e);
  }
  return p;
}

struct Fixture {
  testing::TempDir dir;
  v1::DaemonConfig config = testing::default_config();
  RecordingSink sink;
  std::unique_ptr<InstrumentService> service;

  Fixture() { config.mutable_recorder()->set_data_dir(dir.path().string()); }
  void start() {
    service = std::make_unique<InstrumentService>(config, "test", sink);
    sink.service = service.get();
  }
  void run(const v1::Protocol& protocol) {
    v1::LoadProtocolReply loaded;
    ASSERT_FALSE(service->load_protocol(protocol, loaded));
    v1::StartRunReply started;
    ASSERT_FALSE(service->start_run(std::nullopt, started));
    service->wait_until_idle();
  }
};

TEST(InstrumentService, AbortUnloadsSafelyHoldsTheTipAndRecordsTheReason) {
  Fixture f;
  f.start();
  f.sink.abort_at_s = 12.0;  // mid-scratch, under 1000 µN
  f.run(standard_protocol());
  ASSERT_EQ(f.sink.stops.size(), 1u);
  const v1::RunStop& stop = f.sink.stops[0];
  EXPECT_EQ(stop.exit_status(), v1::ABORT);
  EXPECT_EQ(stop.reason(), "test abort");
  EXPECT_FALSE(f.sink.gaps);

  // After the abort every sample is flagged, the normal setpoint only falls,
  // reaches zero, and the lateral setpoint is held where it was.
  const auto& b = f.sink.samples;
  int first_unload = -1;
  for (int i = 0; i < sample_count(b); ++i) {
    if (b.status_flags(i) & v1::SAFE_UNLOAD) {
      first_unload = i;
      break;
    }
  }
  ASSERT_GT(first_unload, 0);
  // The first flagged sample also averages ticks from before the abort.
  const double held = b.lateral_setpoint_m(first_unload + 1);
  for (int i = first_unload + 1; i < sample_count(b); ++i) {
    EXPECT_TRUE(b.status_flags(i) & v1::SAFE_UNLOAD);
    EXPECT_LE(b.normal_setpoint_n(i), b.normal_setpoint_n(i - 1) + 1e-15);
    EXPECT_DOUBLE_EQ(b.lateral_setpoint_m(i), held);
  }
  EXPECT_EQ(b.normal_setpoint_n(sample_count(b) - 1), 0.0);
  EXPECT_LT(b.time_s(sample_count(b) - 1), 13.0) << "unloaded within a second";

  // The recording holds the same samples and the stop document.
  std::string error;
  const auto recorded =
      wire::read_run_directory(f.dir.path() / stop.run_id(), error);
  ASSERT_TRUE(recorded) << error;
  EXPECT_EQ(recorded->metadata.stop().exit_status(), v1::ABORT);
  EXPECT_EQ(sample_count(recorded->samples), sample_count(b));
  EXPECT_EQ(stop.sample_count(), static_cast<std::uint64_t>(sample_count(b)));
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
}

TEST(InstrumentService, LateralForceTripFaultsTheRunAndBlocksRestart) {
  Fixture f;
  f.config.mutable_limits()->set_max_lateral_force_n(100e-6);  // the scratch needs ~128 µN
  f.start();
  f.run(standard_protocol());
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].exit_status(), v1::FAULT);
  EXPECT_EQ(f.sink.stops[0].reason().rfind("lateral force beyond the limit: ", 0), 0u)
      << f.sink.stops[0].reason();
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
  v1::StartRunReply reply;
  const auto error = f.service->start_run(std::nullopt, reply);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::WRONG_STATE);
  // The unload after the trip ends with the load off.
  const auto& b = f.sink.samples;
  EXPECT_EQ(b.normal_setpoint_n(sample_count(b) - 1), 0.0);
}

TEST(InstrumentService, RejectedProtocolMovesNothingAndRecordsNothing) {
  Fixture f;
  f.start();
  v1::Protocol p = standard_protocol();
  p.mutable_segments(1)->mutable_normal()->set_end_un(20000);
  v1::LoadProtocolReply reply;
  const auto error = f.service->load_protocol(p, reply);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::INVALID_ARGUMENT);
  EXPECT_EQ(error->field(), "segments[1].normal.end_uN");
  EXPECT_EQ(f.service->status().state(), v1::IDLE);
  v1::StartRunReply started;
  EXPECT_TRUE(f.service->start_run(std::nullopt, started));
  EXPECT_TRUE(std::filesystem::is_empty(f.dir.path()));
}

}  // namespace
}  // namespace tribo::daemon
