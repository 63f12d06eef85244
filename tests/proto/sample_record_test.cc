#include "proto/sample_record.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "proto/run_files.h"
#include "proto/text_format_file.h"
#include "tests/support/daemon_process.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo {
namespace {

Sample awkward_sample() {
  return Sample{0.1 + 0.2, 3, 1e-3 / 3, 9.999999999999999e-4, -3.2e-8, 2e-6 / 7, 1.0e-5 + 1e-21,
                -std::numeric_limits<double>::denorm_min(), 5};
}

TEST(SampleRecord, CsvRowRoundTripsBitExactly) {
  const Sample s = awkward_sample();
  std::string row;
  append_csv_row(s, row);
  ASSERT_EQ(row.back(), '\n');
  row.pop_back();
  Sample back;
  ASSERT_TRUE(parse_csv_row(row, back));
  EXPECT_EQ(back, s);
}

TEST(SampleRecord, CsvRejectsMalformedRows) {
  Sample s;
  EXPECT_FALSE(parse_csv_row("1,2,3", s));
  EXPECT_FALSE(parse_csv_row("1,0,0,0,0,0,0,0,x", s));
  EXPECT_FALSE(parse_csv_row("1,0,0,0,0,0,0,0,0,9", s));
}

TEST(SampleRecord, HeaderNamesEveryChannelWithItsUnit) {
  EXPECT_EQ(csv_header(),
            "t_s,segment_index,normal_setpoint_N,normal_force_N,normal_displacement_m,"
            "lateral_setpoint_m,lateral_position_m,lateral_force_N,flags_bits\n");
}

TEST(SampleRecord, BlockRoundTripsSamples) {
  v1::SampleBlock block;
  append_sample(awkward_sample(), block);
  append_sample(Sample{}, block);
  ASSERT_EQ(sample_count(block), 2);
  EXPECT_EQ(sample_at(block, 0), awkward_sample());
  EXPECT_EQ(sample_at(block, 1), Sample{});
}

TEST(RunFiles, WrittenRunReadsBackIdentically) {
  testing::TempDir dir;
  v1::RunMetadata metadata;
  metadata.mutable_start()->set_run_id("r1");
  metadata.mutable_start()->set_seed(42);
  metadata.mutable_stop()->set_exit_status(v1::SUCCESS);
  v1::SampleBlock samples;
  append_sample(awkward_sample(), samples);
  std::string error;
  ASSERT_TRUE(wire::write_run_directory(dir.path() / "run", metadata, samples, error)) << error;
  const auto back = wire::read_run_directory(dir.path() / "run", error);
  ASSERT_TRUE(back) << error;
  EXPECT_EQ(back->metadata.start().seed(), 42u);
  EXPECT_EQ(back->metadata.stop().exit_status(), v1::SUCCESS);
  ASSERT_EQ(sample_count(back->samples), 1);
  EXPECT_EQ(sample_at(back->samples, 0), awkward_sample());
}

TEST(TextFormat, ErrorNamesTheUnknownFieldAndItsLine) {
  v1::Protocol protocol;
  const auto error = wire::parse_text_proto("name: \"x\"\nsegments {\n  duraton_s: 5\n}\n",
                                            "bad.textproto", protocol);
  ASSERT_TRUE(error);
  EXPECT_NE(error->find("bad.textproto:3:"), std::string::npos) << *error;
  EXPECT_NE(error->find("duraton_s"), std::string::npos) << *error;
}

TEST(TextFormat, ErrorNamesTheFieldWithAWrongType) {
  v1::Protocol protocol;
  const auto error =
      wire::parse_text_proto("segments { duration_s: \"five\" }", "p.textproto", protocol);
  ASSERT_TRUE(error);
  EXPECT_NE(error->find("duration_s"), std::string::npos) << *error;
}

}  // namespace
}  // namespace tribo
