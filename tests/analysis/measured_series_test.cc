#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "analysis/input/measured_series.h"
#include "analysis/input/series_input.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"

namespace tribo::analysis {
namespace {

// A file in the temp directory for one test, removed when it goes out of
// scope (the two CSV tests left theirs behind on every run).
struct TempFile {
  TempFile(const std::string& name, const std::string& content)
      : path(std::filesystem::temp_directory_path() / ("tribo_analysis_" + std::to_string(::getpid()) + "_" + name)) {
    std::ofstream(path) << content;
  }
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  std::filesystem::path path;
};

TEST(SeriesInput, MapsNamedColumnsInAnyOrderAndScalesTheForce) {
  const TempFile file("map.csv", "force,t,x,extra\n1.5,0,0.1,9\n-2.5,0.5,0.2,9\n");
  ColumnMapping c;
  c.time = "t";
  c.position = "x";
  c.force = "force";
  c.force_scale = -1;
  std::string error;
  const auto s = read_csv_series(file.path, c, error);
  ASSERT_TRUE(s) << error;
  ASSERT_EQ(s->size(), 2u);
  EXPECT_EQ(s->time_s[1], 0.5);
  EXPECT_EQ(s->position_m[0], 0.1);
  EXPECT_EQ(s->force_n[0], -1.5);
  EXPECT_EQ(s->force_n[1], 2.5);
  EXPECT_FALSE(s->has_normal());
  EXPECT_TRUE(s->velocity_m_per_s.empty());
}

TEST(SeriesInput, NamesTheMissingColumnAndTheBadRow) {
  const TempFile file("bad.csv", "t,x,f\n0,0,1\n0.1,oops,2\n");
  ColumnMapping c;
  c.time = "t";
  c.position = "x";
  c.force = "f";
  std::string error;
  EXPECT_FALSE(read_csv_series(file.path, c, error));
  EXPECT_NE(error.find(":3:"), std::string::npos) << error;
  EXPECT_NE(error.find("'x'"), std::string::npos) << error;
  c.normal = "N";
  EXPECT_FALSE(read_csv_series(file.path, c, error));
  EXPECT_NE(error.find("'N' not in the header"), std::string::npos) << error;
}

TEST(SeriesInput, ReadsATriboRunDirectory) {
  v1::RunMetadata metadata;
  metadata.mutable_start()->set_run_id("test-run");
  v1::SampleBlock block;
  for (int i = 0; i < 20; ++i) {
    Sample s;
    s.time_s = 0.001 * i;
    s.segment_index = i < 10 ? 0 : 1;
    s.normal_setpoint_n = 1e-3;
    s.normal_force_n = 0.99e-3;
    s.lateral_setpoint_m = 1e-6 * i;
    s.lateral_position_m = 0.9e-6 * i;
    s.lateral_force_n = 1e-4;
    s.status_flags = i == 19 ? v1::SAFE_UNLOAD : 0;
    append_sample(s, block);
  }
  const auto dir = std::filesystem::temp_directory_path() / ("tribo_analysis_run_" + std::to_string(::getpid()));
  std::string error;
  ASSERT_TRUE(wire::write_run_directory(dir, metadata, block, error)) << error;
  const auto s = read_run_series(dir, error);
  ASSERT_TRUE(s) << error;
  EXPECT_EQ(s->size(), 19u);  // the SAFE_UNLOAD sample is dropped
  EXPECT_EQ(s->position_m[5], 0.9e-6 * 5);
  EXPECT_EQ(s->reference_m[5], 1e-6 * 5);
  EXPECT_EQ(s->normal_force_n[3], 0.99e-3);
  EXPECT_EQ(s->segment[12], 1u);
  std::filesystem::remove_all(dir);
}

// The reader takes a run directory page by page: a record of several pages,
// with a dropped sample at a page's edge, reads back whole and in order.
TEST(SeriesInput, ReadsARunDirectoryOfManyPagesInOrder) {
  v1::RunMetadata metadata;
  metadata.mutable_start()->set_run_id("test-run-long");
  v1::SampleBlock block;
  const int n = 150001, unloading = 65535;
  for (int i = 0; i < n; ++i) {
    Sample s;
    s.time_s = 0.001 * i;
    s.lateral_position_m = 1e-9 * i;
    s.lateral_force_n = 1e-6 * (i % 7);
    s.status_flags = i == unloading ? v1::SAFE_UNLOAD : 0;
    append_sample(s, block);
  }
  const auto dir = std::filesystem::temp_directory_path() / ("tribo_analysis_long_run_" + std::to_string(::getpid()));
  std::string error;
  ASSERT_TRUE(wire::write_run_directory(dir, metadata, block, error)) << error;
  const auto s = read_run_series(dir, error);
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(s) << error;
  ASSERT_EQ(s->size(), static_cast<std::size_t>(n - 1));
  for (std::size_t k = 0; k < s->size(); ++k) {
    const int i = static_cast<int>(k) + (static_cast<int>(k) >= unloading ? 1 : 0);
    ASSERT_EQ(s->time_s[k], 0.001 * i) << k;
    ASSERT_EQ(s->position_m[k], 1e-9 * i) << k;
    ASSERT_EQ(s->force_n[k], 1e-6 * (i % 7)) << k;
  }
}

// A CSV whose last line has no newline reads it too.
TEST(SeriesInput, ReadsALastLineWithoutItsNewline) {
  const TempFile file("no_newline.csv", "t,x,f\n0,0,1\n0.1,0.2,2\n0.2,0.4,3");
  ColumnMapping c;
  c.time = "t";
  c.position = "x";
  c.force = "f";
  std::string error;
  const auto s = read_csv_series(file.path, c, error);
  ASSERT_TRUE(s) << error;
  ASSERT_EQ(s->size(), 3u);
  EXPECT_EQ(s->force_n[2], 3.0);
}

TEST(MeasuredSeries, DerivesVelocityAndAccelerationByCentralDifferences) {
  MeasuredSeries s;
  for (int i = 0; i < 50; ++i) {
    const double t = 0.01 * i;
    s.time_s.push_back(t);
    s.position_m.push_back(3 * t * t);  // v = 6 t, a = 6
    s.force_n.push_back(0);
  }
  derive_motion(s, 0);
  EXPECT_NEAR(s.velocity_m_per_s[20], 6 * 0.2, 1e-12);
  EXPECT_NEAR(s.acceleration_m_per_s2[20], 6, 1e-9);
  EXPECT_FALSE(s.velocity_measured);
  EXPECT_EQ(check_series(s), "");
  s.time_s[30] = s.time_s[29];
  EXPECT_NE(check_series(s).find("time does not increase at row 31"), std::string::npos);
}

}  // namespace
}  // namespace tribo::analysis
