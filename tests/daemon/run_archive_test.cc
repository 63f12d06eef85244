// The archive's listing cache: a run's listing is kept while its
// metadata.json keeps its size and modification time, and read afresh when
// either changes; a run being recorded has its samples counted afresh; a run
// that is gone leaves the listing.
#include "daemon/run_archive.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "tests/support/daemon_process.h"

namespace tribo::daemon {
namespace {

namespace fs = std::filesystem;

v1::SampleBlock samples(int n) {
  v1::SampleBlock b;
  for (int i = 0; i < n; ++i) append_sample(Sample{i * 1e-3}, b);
  return b;
}

v1::RunMetadata metadata(const std::string& run_id, const std::string& protocol_name, bool finalized) {
  v1::RunMetadata m;
  m.mutable_start()->set_run_id(run_id);
  m.mutable_start()->mutable_protocol()->set_name(protocol_name);
  if (finalized) {
    m.mutable_stop()->set_exit_status(v1::SUCCESS);
    m.mutable_stop()->set_sample_count(5);
  }
  return m;
}

void write_run(const fs::path& dir, const v1::RunMetadata& m, int n) {
  std::string error;
  ASSERT_TRUE(wire::write_run_directory(dir, m, samples(n), error)) << error;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Renames the run's protocol "alpha" to "gamma" in metadata.json, keeping the
// file's size and modification time: a reader trusting the stamp sees no change.
void rename_alpha_keeping_the_stamp(const fs::path& run) {
  const fs::path file = run / wire::kMetadataFile;
  const auto modified = fs::last_write_time(file);
  std::string text = read_text(file);
  const auto at = text.find("alpha");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 5, "gamma");
  std::ofstream(file, std::ios::trunc) << text;
  fs::last_write_time(file, modified);
}

TEST(RunArchive, KeepsAFinalizedListingUntilItsMetadataFileChanges) {
  testing::TempDir data;
  const fs::path run = data.path() / "20260101-000000-000";
  write_run(run, metadata("20260101-000000-000", "alpha", true), 5);
  RunArchive archive(data.path());
  ASSERT_EQ(archive.list_runs(v1::ListRuns{}).runs(0).protocol_name(), "alpha");

  // Same size, same modification time, different content: the kept listing
  // stands (the file is not read again).
  const fs::path file = run / wire::kMetadataFile;
  const auto modified = fs::last_write_time(file);
  rename_alpha_keeping_the_stamp(run);
  EXPECT_EQ(archive.list_runs(v1::ListRuns{}).runs(0).protocol_name(), "alpha");

  // A rewrite that changes the time (or the size) is read.
  write_run(run, metadata("20260101-000000-000", "beta", true), 5);
  fs::last_write_time(file, modified + std::chrono::seconds(1));
  EXPECT_EQ(archive.list_runs(v1::ListRuns{}).runs(0).protocol_name(), "beta");
}

TEST(RunArchive, ARunBeingRecordedIsCountedAfreshAndARemovedRunLeaves) {
  testing::TempDir data;
  const fs::path done = data.path() / "20260101-000000-000";
  const fs::path going = data.path() / "20260102-000000-000";
  write_run(done, metadata("20260101-000000-000", "done", true), 5);
  write_run(going, metadata("20260102-000000-000", "going", false), 3);
  RunArchive archive(data.path());
  auto listing = archive.list_runs(v1::ListRuns{});
  ASSERT_EQ(listing.runs_size(), 2);
  EXPECT_EQ(listing.runs(0).run_id(), "20260102-000000-000");
  EXPECT_FALSE(listing.runs(0).finalized());
  EXPECT_EQ(listing.runs(0).sample_count(), 3u);

  // More rows under an unchanged metadata.json.
  const auto modified = fs::last_write_time(going / wire::kMetadataFile);
  std::string row;
  append_csv_row(Sample{9e-3}, row);
  std::ofstream(going / wire::kSamplesFile, std::ios::app) << row;
  fs::last_write_time(going / wire::kMetadataFile, modified);
  listing = archive.list_runs(v1::ListRuns{});
  EXPECT_EQ(listing.runs(0).sample_count(), 4u);

  fs::remove_all(done);
  listing = archive.list_runs(v1::ListRuns{});
  ASSERT_EQ(listing.runs_size(), 1);
  EXPECT_EQ(listing.runs(0).run_id(), "20260102-000000-000");

  // A run that reappears under the same id with other content is read again.
  write_run(done, metadata("20260101-000000-000", "again", true), 5);
  listing = archive.list_runs(v1::ListRuns{});
  ASSERT_EQ(listing.runs_size(), 2);
  EXPECT_EQ(listing.runs(1).protocol_name(), "again");
}

// Clients poll the listing while a run records: its metadata.json (start
// document, protocol, config) is parsed once, its samples counted each time,
// and its stop document (a rewrite) is seen at once.
TEST(RunArchive, ARunBeingRecordedKeepsItsListingAndIsSeenWhenItStops) {
  testing::TempDir data;
  const fs::path going = data.path() / "20260102-000000-000";
  write_run(going, metadata("20260102-000000-000", "alpha", false), 3);
  RunArchive archive(data.path());
  ASSERT_EQ(archive.list_runs(v1::ListRuns{}).runs(0).protocol_name(), "alpha");

  // Same size and time, other content, two more rows: the kept listing with the new count.
  rename_alpha_keeping_the_stamp(going);
  std::string rows;
  append_csv_row(Sample{3e-3}, rows);
  append_csv_row(Sample{4e-3}, rows);
  std::ofstream(going / wire::kSamplesFile, std::ios::app) << rows;
  auto listing = archive.list_runs(v1::ListRuns{});
  EXPECT_EQ(listing.runs(0).protocol_name(), "alpha");
  EXPECT_FALSE(listing.runs(0).finalized());
  EXPECT_EQ(listing.runs(0).sample_count(), 5u);

  // The stop document arrives.
  write_run(going, metadata("20260102-000000-000", "alpha", true), 5);
  listing = archive.list_runs(v1::ListRuns{});
  EXPECT_TRUE(listing.runs(0).finalized());
  EXPECT_EQ(listing.runs(0).exit_status(), v1::SUCCESS);
}

}  // namespace
}  // namespace tribo::daemon
