// `tribo run` streams to disk: the run's samples.csv is written as
// blocks arrive, holes left by gap notices are filled from the recording, and
// the summary is read back a segment at a time within a cap -- identical to
// the summary from every sample in memory.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/metrics/segment_spans.h"
#include "client/run_stream_writer.h"
#include "client/run_summary.h"
#include "client/segment_reader.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::client {
namespace {

namespace fs = std::filesystem;
using daemon::testing::ServiceFixture;

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Samples [from, end) of all.
v1::SampleBlock slice(const v1::SampleBlock& all, std::uint64_t from, std::uint64_t end) {
  v1::SampleBlock b;
  b.set_first_sequence(from);
  for (std::uint64_t i = from; i < end && i < static_cast<std::uint64_t>(sample_count(all)); ++i) {
    append_sample(sample_at(all, static_cast<int>(i)), b);
  }
  return b;
}

// The recording, paged as the daemon pages FetchSamples.
RunStreamWriter::FetchPages fetch_from(const v1::SampleBlock& all) {
  return [&all](std::uint64_t from, std::uint64_t end, const std::function<void(const v1::SampleBlock&)>& page) {
    for (std::uint64_t p = from; p < end; p += 700) page(slice(all, p, std::min(end, p + 700)));
  };
}

// A run recorded in-process from a shipped protocol.
RunResult recorded_run(const std::string& protocol_file) {
  ServiceFixture f;
  f.start();
  f.run(daemon::testing::load_protocol_file(protocol_file));
  EXPECT_FALSE(f.sink.gaps);
  RunResult run;
  run.start = f.sink.starts.at(0);
  run.stop = f.sink.stops.at(0);
  run.samples = f.sink.samples;
  return run;
}

// Streams run into dir as `tribo run` does: blocks of 1000 in order, except
// that the blocks in [hole_from, hole_end) never arrive (a gap notice).
void stream_to(const RunResult& run, const fs::path& dir, std::uint64_t hole_from, std::uint64_t hole_end,
               RunStreamWriter& writer) {
  std::string error;
  ASSERT_TRUE(writer.open(dir, error)) << error;
  const auto n = static_cast<std::uint64_t>(sample_count(run.samples));
  for (std::uint64_t from = 0; from < n; from += 1000) {
    if (from >= hole_from && from < hole_end) continue;
    ASSERT_TRUE(writer.append(slice(run.samples, from, from + 1000)));
  }
  ASSERT_TRUE(writer.finish(run.stop.sample_count(), fetch_from(run.samples), run.metadata(), error)) << error;
}

class StreamedSummary : public ::testing::TestWithParam<const char*> {};

TEST_P(StreamedSummary, IsIdenticalToTheInMemoryOneAndTheFileToTheRecording) {
  const RunResult run = recorded_run(GetParam());
  const v1::RunSummary in_memory = summarize_run(run);
  ASSERT_GT(in_memory.scratches_size() + in_memory.oscillations_size(), 0);

  tribo::testing::TempDir out;
  RunStreamWriter writer;
  stream_to(run, out.path() / "run", 5000, 9000, writer);
  EXPECT_EQ(writer.fetched_samples(), 4000u);
  EXPECT_EQ(writer.missing_samples(), 0u);
  EXPECT_EQ(writer.peak_samples_held(), 1000u);
  // The same bytes as the whole run written at once.
  std::string error;
  ASSERT_TRUE(wire::write_run_directory(out.path() / "whole", run.metadata(), run.samples, error)) << error;
  EXPECT_TRUE(slurp(out.path() / "run" / wire::kSamplesFile) == slurp(out.path() / "whole" / wire::kSamplesFile));
  EXPECT_EQ(slurp(out.path() / "run" / wire::kMetadataFile), slurp(out.path() / "whole" / wire::kMetadataFile));
  EXPECT_FALSE(fs::exists(out.path() / "run" / "samples.csv.tmp"));
  EXPECT_FALSE(fs::exists(out.path() / "run" / "samples.csv.merge.tmp"));

  std::uint64_t held = 0;
  const auto streamed = summarize_recording(run, out.path() / "run", kSegmentCapSamples, error, &held);
  ASSERT_TRUE(streamed) << error;
  // Bit for bit: every double of every segment.
  EXPECT_EQ(streamed->SerializeAsString(), in_memory.SerializeAsString()) << summary_text(*streamed) << "\n"
                                                                         << summary_text(in_memory);
  EXPECT_EQ(summary_text(*streamed), summary_text(in_memory));
  EXPECT_EQ(summary_json(*streamed), summary_json(in_memory));
  // One segment and one page at most, not the run.
  std::uint64_t longest = 0;
  for (const auto& span : analysis::segment_spans(run.samples)) {
    longest = std::max(longest, static_cast<std::uint64_t>(span.last - span.first + 1));
  }
  EXPECT_LE(held, longest + wire::RowIndex::kStride);
  EXPECT_LT(held, static_cast<std::uint64_t>(sample_count(run.samples)));
}

// A scratch with a tilt hold (tilt estimate), a hold and passes both ways
// (the tilt correction), an oscillation run, and a run of many repeated segments.
INSTANTIATE_TEST_SUITE_P(ShippedProtocols, StreamedSummary,
                         ::testing::Values("standard_scratch_tilt_hold.textproto", "tilt_hold_and_passes.textproto",
                                           "oscillation_amplitudes.textproto", "repeated_scratch.textproto"));

TEST(RunStreamWriter, KeepsSequenceOrderAcrossOverlapsAndCountsWhatTheRecordingLacks) {
  v1::SampleBlock all;
  for (int i = 0; i < 50; ++i) {
    Sample s;
    s.time_s = i * 1e-3;
    s.lateral_force_n = i;
    append_sample(s, all);
  }
  tribo::testing::TempDir out;
  RunStreamWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(out.path(), error)) << error;
  ASSERT_TRUE(writer.append(slice(all, 0, 10)));
  ASSERT_TRUE(writer.append(slice(all, 5, 20)));   // overlaps: only 10..19 are new
  ASSERT_TRUE(writer.append(slice(all, 30, 40)));  // 20..29 missed
  // The recording has 20..24 only, and the stream's tail 40..49 is missed too.
  const v1::SampleBlock recording = slice(all, 0, 25);
  ASSERT_TRUE(writer.finish(50, fetch_from(recording), v1::RunMetadata(), error)) << error;
  ASSERT_EQ(writer.holes().size(), 2u);
  EXPECT_EQ(writer.fetched_samples(), 5u);
  EXPECT_EQ(writer.missing_samples(), 15u);
  EXPECT_EQ(writer.rows(), 35u);
  v1::SampleBlock back;
  wire::RowsRead read;
  ASSERT_TRUE(wire::read_sample_rows(out.path(), {}, back, read, error)) << error;
  ASSERT_EQ(sample_count(back), 35);
  for (int i = 0; i < 25; ++i) EXPECT_EQ(back.lateral_force_n(i), i);
  for (int i = 25; i < 35; ++i) EXPECT_EQ(back.lateral_force_n(i), i + 5);
}

TEST(RunStreamWriter, ReplacesAPlantedTemporaryInsteadOfFollowingIt) {
  tribo::testing::TempDir out;
  const fs::path victim = out.path() / "victim";
  std::ofstream(victim) << "keep me";
  fs::create_directories(out.path() / "run");
  fs::create_symlink(victim, out.path() / "run" / "samples.csv.tmp");
  RunStreamWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(out.path() / "run", error)) << error;
  v1::SampleBlock b;
  append_sample(Sample{}, b);
  ASSERT_TRUE(writer.append(b));
  ASSERT_TRUE(writer.finish(1, {}, v1::RunMetadata(), error)) << error;
  EXPECT_EQ(slurp(victim), "keep me");
  EXPECT_FALSE(fs::is_symlink(out.path() / "run" / wire::kSamplesFile));
  EXPECT_EQ(wire::count_recorded_samples(out.path() / "run"), 1u);
}

TEST(RunStreamWriter, AnUnfinishedRunLeavesNoSamplesFile) {
  tribo::testing::TempDir out;
  {
    RunStreamWriter writer;
    std::string error;
    ASSERT_TRUE(writer.open(out.path(), error)) << error;
    v1::SampleBlock b;
    append_sample(Sample{}, b);
    ASSERT_TRUE(writer.append(b));
  }  // the connection failed mid-run, say
  EXPECT_FALSE(fs::exists(out.path() / wire::kSamplesFile));
  EXPECT_FALSE(fs::exists(out.path() / "samples.csv.tmp"));
}

// A loaded scratch of one long segment: 20 000 samples at 1 kHz, 2 µm/s.
v1::SampleBlock long_scratch() {
  v1::SampleBlock b;
  for (int i = 0; i < 20000; ++i) {
    Sample s;
    s.time_s = i * 1e-3;
    s.normal_setpoint_n = s.normal_force_n = 1e-3;
    s.lateral_setpoint_m = 2e-6 * s.time_s;
    s.lateral_position_m = s.lateral_setpoint_m - 1e-8;
    s.lateral_force_n = 1e-4 + 1e-6 * ((i * 7919) % 13 - 6);  // ripple around 100 µN
    append_sample(s, b);
  }
  return b;
}

TEST(SegmentReader, ThinsASegmentLongerThanTheCapAndSaysSo) {
  RunResult run;
  run.samples = long_scratch();
  run.stop.set_sample_count(20000);
  run.start.set_loop_rate_hz(1000);
  const v1::RunSummary whole = summarize_run(run);
  ASSERT_EQ(whole.scratches_size(), 1);

  tribo::testing::TempDir out;
  RunStreamWriter writer;
  stream_to(run, out.path(), 0, 0, writer);
  std::string error;
  std::uint64_t held = 0;
  const auto thinned = summarize_recording(run, out.path(), 3000, error, &held);
  ASSERT_TRUE(thinned) << error;
  EXPECT_LE(held, 3000u + wire::RowIndex::kStride);
  ASSERT_EQ(thinned->scratches_size(), 1);
  const auto& t = thinned->scratches(0);
  EXPECT_EQ(t.sample_stride(), 8u);  // 20 000 samples in 3 000: halved three times
  EXPECT_EQ(thinned->sample_count(), 20000u);
  EXPECT_NEAR(t.mean_friction_un(), whole.scratches(0).mean_friction_un(), 0.5);
  EXPECT_NEAR(t.measured_velocity_um_s(), 2.0, 1e-6);
  EXPECT_NE(summary_text(*thinned).find("from every 8th sample"), std::string::npos) << summary_text(*thinned);
  EXPECT_FALSE(whole.scratches(0).has_sample_stride());
  EXPECT_EQ(summary_text(whole).find("from every"), std::string::npos);
}

}  // namespace
}  // namespace tribo::client
