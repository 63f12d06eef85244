// Nothing reaches the instrument unchecked, no sample is lost unseen. Each
// test here guards a defect that was found; each failed on the code before
// the fix (see the commit messages).
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>

#include <cmath>
#include <fstream>
#include <future>
#include <limits>
#include <set>
#include <string>

#include "daemon/field_bounds.h"
#include "daemon/incomplete_run.h"
#include "daemon/run_archive.h"
#include "daemon/run_recorder.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

using testing::parse_protocol;
using testing::ServiceFixture;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr const char* kScratch = R"(
name: "scratch"
acquisition_rate_hz: 1000
segments { name: "approach" duration_s: 1 normal { end_uN: 0 } lateral { end_um: 4 } }
segments { name: "load" duration_s: 1 normal { end_uN: 1000 } lateral { shape: HOLD } }
segments { name: "scratch" duration_s: 2 normal { shape: HOLD } lateral { end_um: 8 } }
segments { name: "unload" duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
segments { name: "return" duration_s: 1 normal { end_uN: 0 } lateral { end_um: 0 } }
)";

ProtocolCheck check(const v1::Protocol& p) { return validate_protocol(p, tribo::testing::default_config()); }

// The first error's field, or "" when the protocol passes.
std::string first_error_field(const v1::Protocol& p) {
  const ProtocolCheck c = check(p);
  return c.ok() ? "" : c.errors.front().field;
}

// ---------------------------------------------------------------- item 1

TEST(NonFiniteValues, EveryNumericFieldMustBeFinite) {
  const v1::Protocol good = parse_protocol(kScratch);
  ASSERT_TRUE(check(good).ok());
  struct Case {
    const char* what;
    std::function<void(v1::Protocol&)> spoil;
    const char* field;
  };
  const Case cases[] = {
      {"NaN normal end on the last segment", [](v1::Protocol& p) { p.mutable_segments(4)->mutable_normal()->set_end_un(kNaN); },
       "segments[4].normal.end_uN"},
      {"NaN lateral end", [](v1::Protocol& p) { p.mutable_segments(2)->mutable_lateral()->set_end_um(kNaN); },
       "segments[2].lateral.end_um"},
      {"infinite lateral end", [](v1::Protocol& p) { p.mutable_segments(2)->mutable_lateral()->set_end_um(-kInf); },
       "segments[2].lateral.end_um"},
      {"NaN sine end amplitude",
       [](v1::Protocol& p) { p.mutable_segments(2)->mutable_lateral()->mutable_sine()->set_end_amplitude_um(kNaN); },
       "segments[2].lateral.sine.end_amplitude_um"},
      {"NaN duration", [](v1::Protocol& p) { p.mutable_segments(1)->set_duration_s(kNaN); }, "segments[1].duration_s"},
  };
  for (const Case& c : cases) {
    v1::Protocol p = good;
    c.spoil(p);
    EXPECT_EQ(first_error_field(p), c.field) << c.what;
  }
}

TEST(NonFiniteValues, AnAcquisitionRateMustBeAPositiveNumberOrUnset) {
  for (const double rate : {kNaN, -kInf, -1000.0, -0.0}) {
    v1::Protocol p = parse_protocol(kScratch);
    p.set_acquisition_rate_hz(rate);
    EXPECT_EQ(first_error_field(p), "acquisition_rate_hz") << "protocol rate " << rate;
    v1::Protocol q = parse_protocol(kScratch);
    q.mutable_segments(1)->set_acquisition_rate_hz(rate);
    EXPECT_EQ(first_error_field(q), "segments[1].acquisition_rate_hz") << "segment rate " << rate;
  }
}

TEST(NonFiniteValues, ABadDefaultRateIsReportedAgainstTheConfig) {
  v1::DaemonConfig config = tribo::testing::default_config();
  config.mutable_controller()->set_default_acquisition_rate_hz(3);  // does not divide the loop rate
  v1::Protocol p = parse_protocol(kScratch);
  p.set_acquisition_rate_hz(0);
  const ProtocolCheck c = validate_protocol(p, config);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.errors.front().field, "controller.default_acquisition_rate_hz");
}

// ---------------------------------------------------------------- item 8

TEST(BoundedStrings, LongNamesAreRefusedNamingTheField) {
  v1::Protocol p = parse_protocol(kScratch);
  p.set_name(std::string(2 << 20, 'n'));
  EXPECT_EQ(first_error_field(p), "name");
  v1::Protocol q = parse_protocol(kScratch);
  q.mutable_segments(3)->set_name(std::string(1 << 20, 's'));
  EXPECT_EQ(first_error_field(q), "segments[3].name");
  v1::Protocol r = parse_protocol(kScratch);
  r.set_description(std::string(kMaxTextBytes, 'd'));  // at the limit: fine
  EXPECT_TRUE(check(r).ok());
}

TEST(BoundedStrings, ControlCharactersAreNotLoggedAsIs) {
  EXPECT_EQ(printable_prefix("tribo\n[info] forged", 64), "tribo?[info] forged");
  EXPECT_EQ(printable_prefix(std::string(100, 'x'), 10), "xxxxxxxxxx...");
}

// The supervisor refuses a non-finite command whatever the validator said:
// a load function compiled from a valid protocol, then spoiled.
struct WriteRecorder : hal::Transducer {
  explicit WriteRecorder(std::unique_ptr<hal::Transducer> inner) : inner_(std::move(inner)) {}
  std::string_view backend_name() const override { return inner_->backend_name(); }
  double period_s() const override { return inner_->period_s(); }
  hal::IoResult read(hal::SensorFrame& f) override { return inner_->read(f); }
  hal::IoResult write(const hal::DriveCommand& c) override {
    writes.push_back(c);
    return inner_->write(c);
  }
  void wait_next_tick() override { inner_->wait_next_tick(); }
  void interrupt_wait() override { inner_->interrupt_wait(); }
  std::unique_ptr<hal::Transducer> inner_;
  std::vector<hal::DriveCommand> writes;
};

RunOutcome run_spoiled(const std::function<void(SegmentPlan&)>& spoil, int segment, std::vector<hal::DriveCommand>& writes) {
  const v1::DaemonConfig config = tribo::testing::default_config();
  const ProtocolCheck c = check(parse_protocol(kScratch));
  EXPECT_TRUE(c.ok());
  std::vector<SegmentPlan> plans = c.load_function.segments();
  spoil(plans[static_cast<std::size_t>(segment)]);
  const LoadFunction spoiled(std::move(plans), c.load_function.loop_rate_hz());
  WriteRecorder transducer(hal::make_transducer(config, 1));
  SpscQueue<Sample> queue(1 << 17);
  RunControl control;
  RunTelemetry telemetry;
  RunLoop loop(transducer, spoiled, run_loop_config_from(config), queue, control, telemetry);
  Sample s;
  while (loop.tick()) {
    while (queue.try_pop(s)) {
    }
  }
  writes = std::move(transducer.writes);
  return loop.outcome();
}

TEST(CommandGuard, ANonFiniteSetpointTripsAndNothingNonFiniteIsWritten) {
  std::vector<hal::DriveCommand> writes;
  const RunOutcome out = run_spoiled([](SegmentPlan& p) { p.lateral.end = kNaN; }, 2, writes);
  EXPECT_EQ(out.end, RunEnd::kTripped);
  EXPECT_EQ(out.trip.reason, TripReason::kCommandInvalid) << trip_description(out.trip);
  ASSERT_FALSE(writes.empty());
  for (const auto& w : writes) {
    ASSERT_TRUE(std::isfinite(w.normal_force_n) && std::isfinite(w.lateral_force_n));
  }
  // It tripped where the scratch began (2 s), not at the end of the run.
  EXPECT_NEAR(out.trip_time_s, 2.0, 1e-3);
}

TEST(CommandGuard, AnOutOfRangeDriveIsNeverWritten) {
  // A step to 1 N open-loop normal force: far beyond what the amplifier can push.
  std::vector<hal::DriveCommand> writes;
  const RunOutcome out = run_spoiled(
      [](SegmentPlan& p) {
        p.normal.begin = p.normal.end = 1.0;
        p.normal.begin_from_measured = p.normal.begin_continues = p.normal.end_relative = false;
      },
      1, writes);
  EXPECT_EQ(out.end, RunEnd::kTripped);
  EXPECT_EQ(out.trip.reason, TripReason::kCommandInvalid) << trip_description(out.trip);
  const SupervisorParams p = supervisor_params_from_config(tribo::testing::default_config());
  for (const auto& w : writes) ASSERT_LE(w.normal_force_n, p.normal_drive_max_n);
}

// ---------------------------------------------------------------- item 2

// A full disk, played by the file size limit (SIGXFSZ ignored: writes fail
// with EFBIG as they fail with ENOSPC).
struct FileSizeLimit {
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler = signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old);
    rlimit l = old;
    l.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &l);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, old_handler);
  }
  rlimit old{};
  sighandler_t old_handler;
};

TEST(FullDisk, AFailedWriteEndsTheRunAsAFaultNamingTheLostSamples) {
  ServiceFixture f;
  f.start();
  {
    FileSizeLimit limit(250 * 1024);  // the metadata fits; samples.csv fills it after a few thousand rows
    // A 100 s dwell: the simulated loop may run ahead of the recorder by
    // the sample queue (65536 samples, 65.5 s here), and must still be
    // running when the recorder fails.
    f.run(parse_protocol(R"(
      name: "long dwell"
      acquisition_rate_hz: 1000
      segments { name: "approach" duration_s: 1 normal { end_uN: 0 } lateral { end_um: 4 } }
      segments { name: "load" duration_s: 1 normal { end_uN: 1000 } lateral { shape: HOLD } }
      segments { name: "dwell" duration_s: 100 normal { shape: HOLD } lateral { shape: HOLD } }
      segments { name: "unload" duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
    )"));
  }
  ASSERT_EQ(f.sink.stops.size(), 1u);
  const v1::RunStop& stop = f.sink.stops[0];
  EXPECT_EQ(stop.exit_status(), v1::FAULT) << stop.reason();
  EXPECT_NE(stop.reason().find("recording failed"), std::string::npos) << stop.reason();
  EXPECT_TRUE(stop.recording_failed());
  EXPECT_LT(stop.lost_first_sequence(), stop.lost_end_sequence());
  EXPECT_EQ(stop.lost_end_sequence(), stop.sample_count());
  // The run stopped early, through the safe stop sequence.
  const auto& b = f.sink.samples;
  ASSERT_GT(sample_count(b), 0);
  // Within the queue's lead (65.5 s) and the stop sequence of the failure.
  EXPECT_LT(b.time_s(sample_count(b) - 1), static_cast<double>(stop.lost_first_sequence()) / 1000 + 65.6 + 10);
  EXPECT_TRUE(b.status_flags(sample_count(b) - 1) & v1::SAFE_UNLOAD);
  const v1::StatusReply status = f.service->status();
  EXPECT_EQ(status.state(), v1::FAULTED);
  EXPECT_TRUE(status.recording_failed());
  EXPECT_FALSE(status.backend_health().healthy());
  // The file keeps whole rows, exactly the samples before the lost range.
  const auto dir = f.dir.path() / stop.run_id();
  std::ifstream in(dir / "samples.csv", std::ios::binary);
  const std::string csv((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(csv.empty());
  EXPECT_EQ(csv.back(), '\n');
  EXPECT_EQ(static_cast<std::uint64_t>(std::count(csv.begin(), csv.end(), '\n')) - 1, stop.lost_first_sequence());
  // The stop document reached the disk and says the same.
  std::string error;
  const auto metadata = wire::read_run_metadata(dir, error);
  ASSERT_TRUE(metadata) << error;
  EXPECT_EQ(metadata->stop().lost_first_sequence(), stop.lost_first_sequence());
}

// ---------------------------------------------------------------- items 4, 5

TEST(Rearm, ReadsTheContinuingInstrumentAndRefusesAFrozenOne) {
  ServiceFixture f;
  for (const auto channel : {v1::CHANNEL_LATERAL_POSITION, v1::CHANNEL_LATERAL_FORCE, v1::CHANNEL_NORMAL_FORCE,
                             v1::CHANNEL_NORMAL_DISPLACEMENT}) {
    f.add_fault(v1::SENSOR_FREEZE, channel, 3.0, 0);  // frozen from 3 s on, loaded
  }
  f.start();
  f.run(parse_protocol(kScratch));
  ASSERT_EQ(f.service->status().state(), v1::FAULTED);
  v1::RearmReply reply;
  const auto error = f.service->rearm(reply);
  ASSERT_TRUE(error) << "re-armed on a frozen readout reading " << reply.normal_force_n() << " N";
  EXPECT_NE(error->message().find("frozen"), std::string::npos) << error->message();
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
}

TEST(Rearm, AcceptsAnInstrumentAtRestAfterAnEmergencyStop) {
  ServiceFixture f;
  f.start();
  f.sink.at_time_s = 2.5;
  f.sink.at_time = [&] {
    v1::EmergencyStopReply r;
    f.service->emergency_stop("test", r);
  };
  f.run(parse_protocol(kScratch));
  ASSERT_EQ(f.service->status().state(), v1::FAULTED);
  v1::RearmReply reply;
  const auto error = f.service->rearm(reply);
  ASSERT_FALSE(error) << error->message();
  EXPECT_LT(std::fabs(reply.normal_force_n()), 20e-6);
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
}

TEST(Restart, ComesUpLatchedAfterARunThatDidNotFinish) {
  ServiceFixture f;
  {
    // A run cut short: start document written, no stop document.
    v1::RunStart start;
    start.mutable_protocol()->set_name("cut short");
    std::string error;
    auto recorder = RunRecorder::create(f.dir.path(), start, error);
    ASSERT_TRUE(recorder) << error;
  }
  f.start();
  const v1::StatusReply status = f.service->status();
  EXPECT_EQ(status.state(), v1::FAULTED);
  EXPECT_NE(status.trip_reason().find("did not finish"), std::string::npos) << status.trip_reason();
  v1::LoadProtocolReply loaded;
  ASSERT_FALSE(f.service->load_protocol(parse_protocol(kScratch), loaded));
  v1::StartRunReply started;
  EXPECT_TRUE(f.service->start_run(std::nullopt, started));
  v1::RearmReply rearmed;
  const auto error = f.service->rearm(rearmed);
  ASSERT_FALSE(error) << error->message();
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
}

TEST(Restart, NamesTheLastWholeSampleAndWhatIsLost) {
  ServiceFixture f;
  std::filesystem::path run_dir;
  {
    // A crash mid-run: 10 whole rows reached the disk, the 11th is cut short,
    // and there is no stop document.
    v1::RunStart start;
    start.mutable_protocol()->set_name("crashed");
    std::string error;
    auto recorder = RunRecorder::create(f.dir.path(), start, error);
    ASSERT_TRUE(recorder) << error;
    for (int i = 0; i < 10; ++i) recorder->append(Sample{i * 1e-3, 0, 0, 1e-6 * i, 0, 0, 0, 0, 0});
    recorder->flush();
    run_dir = recorder->directory();
  }
  {
    std::ofstream samples(run_dir / wire::kSamplesFile, std::ios::app | std::ios::binary);
    samples << "0.010,0,0,1.0e-";  // the partial row
  }
  f.start();
  const v1::StatusReply status = f.service->status();
  EXPECT_EQ(status.state(), v1::FAULTED);
  EXPECT_NE(status.trip_reason().find("last whole sample recorded is sequence 9"), std::string::npos)
      << status.trip_reason();
  EXPECT_NE(status.trip_reason().find("from sequence 10 on) is lost"), std::string::npos) << status.trip_reason();
  // The run's directory says the same, for whoever reads the run later.
  std::ifstream in(run_dir / kIncompleteRunFile);
  ASSERT_TRUE(in) << "no " << kIncompleteRunFile << " in " << run_dir;
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(doc.find("\"last_whole_sequence\": 9"), std::string::npos) << doc;
  EXPECT_NE(doc.find("\"lost_from_sequence\": 10"), std::string::npos) << doc;
  EXPECT_NE(doc.find("\"partial_last_row\": true"), std::string::npos) << doc;
  // Still latched at the next start-up, until a re-arm.
  f.service.reset();
  f.start();
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
}

TEST(Restart, AFinishedPreviousRunLeavesTheDaemonIdle) {
  ServiceFixture f;
  f.start();
  f.run(parse_protocol(kScratch));
  f.service.reset();
  f.start();
  EXPECT_EQ(f.service->status().state(), v1::IDLE);
}

TEST(Session, RunsOnTheOneBackendStayBitIdentical) {
  ServiceFixture f;
  f.start();
  f.run(parse_protocol(kScratch));
  const v1::SampleBlock first = f.sink.samples;
  f.sink.clear();
  v1::StartRunReply started;
  ASSERT_FALSE(f.service->start_run(std::nullopt, started));
  f.service->wait_until_idle();
  ASSERT_EQ(sample_count(f.sink.samples), sample_count(first));
  EXPECT_EQ(f.sink.samples.SerializeAsString().size(), first.SerializeAsString().size());
  for (int i = 0; i < sample_count(first); i += 97) {
    ASSERT_EQ(f.sink.samples.lateral_force_n(i), first.lateral_force_n(i)) << i;
    ASSERT_EQ(f.sink.samples.normal_force_n(i), first.normal_force_n(i)) << i;
  }
}

// ---------------------------------------------------------------- item 3

TEST(Autotune, AnEmergencyStopEndsTheExperimentAndLatches) {
  ServiceFixture f;
  // An experiment of up to 1000 cycles / 600 s: the unpaced loop would finish
  // the config's 5 s one before the stop lands.
  f.config.mutable_autotune()->set_cycles(1000);
  f.config.mutable_autotune()->set_max_duration_s(600);
  f.start();
  std::promise<std::pair<std::optional<v1::Error>, v1::AutotuneReply>> outcome;
  v1::Autotune request;
  f.service->autotune_async(request, [&](std::optional<v1::Error> e, const v1::AutotuneReply& r) {
    outcome.set_value({e, r});
  });
  v1::EmergencyStopReply stopped;
  ASSERT_FALSE(f.service->emergency_stop("test", stopped));
  EXPECT_TRUE(stopped.run_was_active());
  auto [error, reply] = outcome.get_future().get();
  ASSERT_TRUE(error);
  EXPECT_NE(error->message().find("emergency stop"), std::string::npos) << error->message();
  EXPECT_FALSE(reply.has_proposed());
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
  EXPECT_GE(f.service->last_emergency_stop_latency_s(), 0);
}

TEST(Autotune, IsRecordedLikeARun) {
  ServiceFixture f;
  f.start();
  v1::AutotuneReply reply;
  const auto error = f.service->autotune(v1::Autotune{}, reply);
  ASSERT_FALSE(error) << error->message();
  const auto runs = wire::list_recorded_runs(f.dir.path());
  ASSERT_EQ(runs.size(), 1u);
  const v1::RunListing& listed = runs.front();
  EXPECT_EQ(listed.protocol_name(), "autotune");
  EXPECT_TRUE(listed.finalized());
  EXPECT_EQ(listed.exit_status(), v1::SUCCESS) << listed.reason();
  EXPECT_NE(listed.reason().find("Ku"), std::string::npos) << listed.reason();
  std::string read_error;
  const auto run = wire::read_run_directory(f.dir.path() / listed.run_id(), read_error);
  ASSERT_TRUE(run) << read_error;
  // Every recorded sample is on disk, the three phases are there, and the
  // relay's oscillation is in the lateral position.
  EXPECT_EQ(static_cast<std::uint64_t>(sample_count(run->samples)), run->metadata.stop().sample_count());
  EXPECT_GT(sample_count(run->samples), 1000);
  EXPECT_TRUE(run->metadata.has_run_descriptor());
  EXPECT_EQ(run->metadata.run_descriptor().segment_names_size(), 3);
  std::set<std::uint32_t> segments(run->samples.segment_index().begin(), run->samples.segment_index().end());
  EXPECT_EQ(segments, (std::set<std::uint32_t>{0, 1, 2}));
  double lo = 1, hi = -1;
  for (int i = 0; i < sample_count(run->samples); ++i) {
    if (run->samples.segment_index(i) != 1) continue;
    lo = std::min(lo, run->samples.lateral_position_m(i));
    hi = std::max(hi, run->samples.lateral_position_m(i));
  }
  EXPECT_GT(hi - lo, reply.oscillation_amplitude_m()) << "no relay oscillation recorded";
  // Listed and fetched through the archive, as `tribo list` and `tribo fetch` do.
  RunArchive archive(f.dir.path());
  const v1::ListRunsReply listing = archive.list_runs(v1::ListRuns{});
  ASSERT_EQ(listing.runs_size(), 1);
  EXPECT_EQ(listing.runs(0).protocol_name(), "autotune");
  v1::FetchSamples fetch;
  fetch.set_run_id(listed.run_id());
  fetch.set_max_samples(100);
  v1::FetchSamplesReply fetched;
  ASSERT_FALSE(archive.fetch_samples(fetch, fetched));
  ASSERT_EQ(sample_count(fetched.samples()), 100);
  EXPECT_EQ(fetched.samples().lateral_position_m(99), run->samples.lateral_position_m(99));
  // An experiment stopped by an emergency stop is recorded as a FAULT with its
  // fault. On an instrument whose experiment lasts up to 10 minutes (1000
  // cycles): the unpaced loop would finish the 5 s one before the stop lands.
  ServiceFixture g;
  g.config.mutable_autotune()->set_cycles(1000);
  g.config.mutable_autotune()->set_max_duration_s(600);
  g.start();
  std::promise<std::optional<v1::Error>> outcome;
  g.service->autotune_async(v1::Autotune{}, [&](std::optional<v1::Error> e, const v1::AutotuneReply&) {
    outcome.set_value(std::move(e));
  });
  v1::EmergencyStopReply stopped;
  ASSERT_FALSE(g.service->emergency_stop("test: recorded", stopped));
  ASSERT_TRUE(outcome.get_future().get());
  const auto after = wire::list_recorded_runs(g.dir.path());
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after.front().protocol_name(), "autotune");
  EXPECT_EQ(after.front().exit_status(), v1::FAULT);
  EXPECT_NE(after.front().reason().find("test: recorded"), std::string::npos) << after.front().reason();
  const auto metadata = wire::read_run_metadata(g.dir.path() / after.front().run_id(), read_error);
  ASSERT_TRUE(metadata) << read_error;
  EXPECT_EQ(metadata->faults_size(), 1);
}

// ------------------------------------------ segment names, daemon side

TEST(SegmentNames, EventsNameTheUnrolledSegment) {
  ServiceFixture f;
  f.start();
  f.run(parse_protocol(R"(
name: "repeats"
acquisition_rate_hz: 1000
segments { name: "approach" duration_s: 0.5 normal { end_uN: 0 } lateral { end_um: 4 } }
segments { name: "load" duration_s: 0.5 normal { end_uN: 500 } lateral { shape: HOLD } }
segments { name: "passes" repeat { count: 2 alternate_direction: true
  segments { name: "scratch" duration_s: 0.5 normal { shape: HOLD } lateral { end_um: 6 } } } }
segments { name: "unload" duration_s: 0.5 normal { end_uN: 0 } lateral { shape: HOLD } }
)"));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  ASSERT_EQ(f.sink.stops[0].exit_status(), v1::SUCCESS) << f.sink.stops[0].reason();
  ASSERT_EQ(f.sink.starts.size(), 1u);
  const auto& segments = f.sink.starts[0].segments();
  ASSERT_EQ(segments.size(), 5);
  std::vector<std::string> names;
  for (const auto& e : f.sink.events) {
    if (e.kind() != v1::SEGMENT_BEGIN) continue;
    ASSERT_LT(e.segment_index(), static_cast<std::uint32_t>(segments.size()));
    EXPECT_EQ(e.segment_name(), segments[static_cast<int>(e.segment_index())].name()) << e.segment_index();
    names.push_back(e.segment_name());
  }
  ASSERT_EQ(names.size(), 5u);
  EXPECT_EQ(names[4], "unload");
  EXPECT_NE(names[2].find("scratch"), std::string::npos) << names[2];
  EXPECT_NE(names[3].find("scratch"), std::string::npos) << names[3];
}

TEST(Annotations, GoIntoTheStartDocumentAndTheListing) {
  ServiceFixture f;
  f.start();
  v1::LoadProtocolReply loaded;
  ASSERT_FALSE(f.service->load_protocol(parse_protocol(kScratch), loaded));
  v1::RunAnnotations a;
  a.set_sample("DLC on Si, wafer 3");
  a.set_tip("diamond 5 µm");
  a.set_operator_name("ada");
  a.set_note("after cleaning");
  (*a.mutable_extra())["humidity_pct"] = "41";
  v1::StartRunReply started;
  ASSERT_FALSE(f.service->start_run(std::nullopt, started, a));
  f.service->wait_until_idle();
  ASSERT_EQ(f.sink.starts.size(), 1u);
  EXPECT_EQ(f.sink.starts[0].annotations().SerializeAsString(), a.SerializeAsString());
  RunArchive archive(f.dir.path());
  const v1::ListRunsReply listing = archive.list_runs(v1::ListRuns{});
  ASSERT_EQ(listing.runs_size(), 1);
  EXPECT_EQ(listing.runs(0).annotations().sample(), "DLC on Si, wafer 3");
  EXPECT_EQ(listing.runs(0).annotations().extra().at("humidity_pct"), "41");

  v1::RunAnnotations long_note = a;
  long_note.set_note(std::string(kMaxTextBytes + 1, 'x'));
  const auto error = f.service->start_run(std::nullopt, started, long_note);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::INVALID_ARGUMENT);
  EXPECT_EQ(error->field(), "start_run.annotations.note");
}

}  // namespace
}  // namespace tribo::daemon

namespace tribo::daemon {
namespace {

// Item 11: a position ADC at its rail reads one code while the tip moves on
// (the simulated one saturated at +13.77 µm inside the ±15 µm travel). Played
// here by freezing the position channel alone mid-scratch: the setpoint moves
// on, the reading does not.
TEST(SaturatedReading, APositionStuckWhileItsSetpointMovesTrips) {
  testing::ServiceFixture f;
  f.add_fault(v1::SENSOR_FREEZE, v1::CHANNEL_LATERAL_POSITION, 2.5, 0);
  f.start();
  f.run(testing::parse_protocol(kScratch));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  const v1::RunStop& stop = f.sink.stops[0];
  EXPECT_EQ(stop.exit_status(), v1::FAULT) << stop.reason();
  EXPECT_NE(stop.reason().find("stuck"), std::string::npos) << stop.reason();
}

}  // namespace
}  // namespace tribo::daemon

namespace tribo::daemon {
namespace {

// Item 10: segment events are appended as they happen (one line each in
// events.jsonl), not by rewriting metadata.json per event (O(n^2) in the
// segments); metadata.json gets them all once, with the stop document.
TEST(RunDocuments, SegmentEventsAreAppendedAndFinalizedOnce) {
  testing::ServiceFixture f;
  f.start();
  std::string text = "name: \"many\" acquisition_rate_hz: 1000\n";
  text += "segments { name: \"approach\" duration_s: 0.1 normal { end_uN: 0 } lateral { end_um: 4 } }\n";
  text += "segments { name: \"hops\" repeat { count: 200 segments { name: \"hop\" duration_s: 0.002 "
          "normal { end_uN: 0 } lateral { shape: HOLD } } } }\n";
  f.run(testing::parse_protocol(text));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  ASSERT_EQ(f.sink.stops[0].exit_status(), v1::SUCCESS) << f.sink.stops[0].reason();
  const auto dir = f.dir.path() / f.sink.stops[0].run_id();
  std::ifstream events(dir / RunRecorder::kEventsFile);
  std::string line;
  std::size_t lines = 0;
  while (std::getline(events, line)) ++lines;
  EXPECT_EQ(lines, f.sink.events.size());
  EXPECT_GE(lines, 201u);
  std::string error;
  const auto metadata = wire::read_run_metadata(dir, error);
  ASSERT_TRUE(metadata) << error;
  EXPECT_EQ(static_cast<std::size_t>(metadata->segment_events_size()), lines);
}

}  // namespace
}  // namespace tribo::daemon
