#include "proto/run_files.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "proto/sample_record.h"
#include "tests/support/daemon_process.h"

namespace tribo::wire {
namespace {

v1::SampleBlock samples(int n) {
  v1::SampleBlock b;
  for (int i = 0; i < n; ++i) {
    append_sample(Sample{i * 1e-3, static_cast<std::uint32_t>(i / 10), 1e-3, 0.99e-3 + i * 1e-9, 1e-7,
                         2e-6, 2e-6 - 1e-7, 1.27e-4 + i * 1e-12, static_cast<std::uint32_t>(i % 3)},
                  b);
  }
  return b;
}

struct RunDir {
  testing::TempDir dir;
  std::filesystem::path path = dir.path() / "20260101-000000-000";
  explicit RunDir(int n) {
    v1::RunMetadata metadata;
    metadata.mutable_start()->set_run_id("20260101-000000-000");
    std::string error;
    if (!write_run_directory(path, metadata, samples(n), error)) throw std::runtime_error(error);
  }
};

TEST(RunFiles, ReadsRangesOfRowsBitIdentical) {
  RunDir run(100);
  v1::SampleBlock block;
  RowsRead read;
  std::string error;
  ASSERT_TRUE(read_sample_rows(run.path, SampleRange{40, 25}, block, read, error)) << error;
  EXPECT_EQ(read.rows, 25u);
  EXPECT_FALSE(read.end_of_file);
  EXPECT_EQ(block.first_sequence(), 40u);
  const v1::SampleBlock all = samples(100);
  for (int i = 0; i < 25; ++i) EXPECT_EQ(sample_at(block, i), sample_at(all, 40 + i));

  v1::SampleBlock tail;
  ASSERT_TRUE(read_sample_rows(run.path, SampleRange{90, 0}, tail, read, error));
  EXPECT_EQ(read.rows, 10u);
  EXPECT_TRUE(read.end_of_file);
  ASSERT_TRUE(read_sample_rows(run.path, SampleRange{500, 10}, tail, read, error));
  EXPECT_EQ(read.rows, 0u);
  EXPECT_EQ(count_recorded_samples(run.path), 100u);
}

TEST(RunFiles, CsvPagesConcatenateToTheFile) {
  RunDir run(100);
  std::string csv;
  RowsRead read;
  std::string error;
  for (std::uint64_t from = 0; from < 100; from += read.rows) {
    ASSERT_TRUE(read_csv_rows(run.path, SampleRange{from, 33}, csv, read, error)) << error;
    ASSERT_GT(read.rows, 0u);
  }
  std::ifstream in(run.path / kSamplesFile, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(csv == file);
}

TEST(RunFiles, PagingWithARowIndexSeeksAndReadsTheSameRows) {
  RunDir run(20000);
  const v1::SampleBlock all = samples(20000);
  RowIndex index;
  std::string error;
  RowsRead read;
  // Pages in order build the index as they go...
  for (std::uint64_t from = 0; from < 20000; from += 3000) {
    v1::SampleBlock page;
    ASSERT_TRUE(read_sample_rows(run.path, SampleRange{from, 3000}, page, read, error, &index)) << error;
    for (int i = 0; i < sample_count(page); ++i) {
      ASSERT_EQ(sample_at(page, i), sample_at(all, static_cast<int>(from) + i)) << from + static_cast<std::uint64_t>(i);
    }
  }
  ASSERT_EQ(index.offsets.size(), 3u);  // rows 0, 8192, 16384
  // ...and a later read starts from the nearest indexed row.
  v1::SampleBlock late;
  ASSERT_TRUE(read_sample_rows(run.path, SampleRange{17000, 5}, late, read, error, &index)) << error;
  ASSERT_EQ(sample_count(late), 5);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(sample_at(late, i), sample_at(all, 17000 + i));
  std::string csv;
  ASSERT_TRUE(read_csv_rows(run.path, SampleRange{16384, 1}, csv, read, error, &index));
  std::string expected;
  append_csv_row(sample_at(all, 16384), expected);
  EXPECT_EQ(csv, expected);
}

// A crash can cut the last row anywhere, even inside its last number, which
// would still parse: only rows that end in a newline count.
TEST(RunFiles, ATornLastRowIsNotASample) {
  RunDir run(10);
  {
    std::ofstream out(run.path / kSamplesFile, std::ios::binary | std::ios::app);
    out << "0.01,1,0.001,0.00099,1e-07,2e-06,1.9e-06,0.000127,1";  // no newline: "1" of "12"?
  }
  EXPECT_EQ(count_recorded_samples(run.path), 10u);
  std::string error;
  const auto read = read_run_directory(run.path, error);
  ASSERT_TRUE(read) << error;
  EXPECT_EQ(sample_count(read->samples), 10);
}

TEST(RunFiles, RunIdsNameOneDirectoryAndNothingElse) {
  for (const char* ok : {"20260101-000000-000", "demo-20261122-084730", "a.b_c"}) EXPECT_TRUE(is_valid_run_id(ok)) << ok;
  for (const char* bad : {"", ".", "..", "../x", "a/b", "/etc", "a\\b", "x y", "a\nb"}) {
    EXPECT_FALSE(is_valid_run_id(bad)) << bad;
  }
}

TEST(RunFiles, ListsRunsNewestFirstWithIncompleteOnes) {
  testing::TempDir dir;
  for (const char* id : {"20260101-000000-000", "20260102-000000-000"}) {
    v1::RunMetadata metadata;
    metadata.mutable_start()->set_run_id(id);
    metadata.mutable_start()->mutable_protocol()->set_name("p");
    if (std::string(id) == "20260101-000000-000") {
      metadata.mutable_stop()->set_exit_status(v1::SUCCESS);
      metadata.mutable_stop()->set_sample_count(5);
    }
    std::string error;
    ASSERT_TRUE(write_run_directory(dir.path() / id, metadata, samples(5), error)) << error;
  }
  std::filesystem::create_directory(dir.path() / "not-a-run");
  const auto runs = list_recorded_runs(dir.path());
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].run_id(), "20260102-000000-000");
  EXPECT_FALSE(runs[0].finalized());
  EXPECT_EQ(runs[0].sample_count(), 5u);
  EXPECT_TRUE(runs[1].finalized());
  EXPECT_EQ(runs[1].exit_status(), v1::SUCCESS);
}

// `tribo run --out` and `tribo fetch` write through write_run_directory: a
// samples.csv.tmp planted as a symlink must not redirect the write.
TEST(RunFiles, APlantedTemporarySymlinkIsReplacedNotFollowed) {
  testing::TempDir dir;
  const std::filesystem::path victim = dir.path() / "victim.txt";
  std::ofstream(victim) << "keep me";
  const std::filesystem::path run = dir.path() / "run";
  std::filesystem::create_directories(run);
  std::filesystem::create_symlink(victim, run / "samples.csv.tmp");
  std::string error;
  ASSERT_TRUE(write_run_directory(run, v1::RunMetadata(), samples(3), error)) << error;
  std::ifstream in(victim);
  const std::string kept((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(kept, "keep me");
  EXPECT_FALSE(std::filesystem::is_symlink(run / "samples.csv"));
  EXPECT_EQ(count_recorded_samples(run), 3u);
  EXPECT_FALSE(std::filesystem::exists(run / "samples.csv.tmp"));
}

}  // namespace
}  // namespace tribo::wire
