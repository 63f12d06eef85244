#include "daemon/protocol_validator.h"

#include <gtest/gtest.h>

#include "proto/text_format_file.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::daemon {
namespace {

v1::Protocol standard_protocol() {
  v1::Protocol p;
  const auto error = wire::load_text_proto_file(
      std::string(TRIBO_SOURCE_DIR) + "/config/protocols/standard_scratch.textproto", p);
  if (error) throw std::runtime_error(*error);
  return p;
}

ProtocolCheck check(const v1::Protocol& p) {
  const v1::DaemonConfig c = testing::default_config();
  return validate_protocol(p, c);
}

// The first error whose field is `field`, or a failure listing all errors.
const ValidationIssue* find(const ProtocolCheck& c, const std::string& field) {
  for (const auto& e : c.errors) {
    if (e.field == field) return &e;
  }
  return nullptr;
}

std::string all(const ProtocolCheck& c) {
  std::string s;
  for (const auto& e : c.errors) s += e.field + ": " + e.message + "\n";
  return s;
}

TEST(ProtocolValidator, AcceptsTheStandardScratchAndCompilesIt) {
  const ProtocolCheck c = check(standard_protocol());
  ASSERT_TRUE(c.ok()) << all(c);
  EXPECT_DOUBLE_EQ(c.duration_s, 32);
  EXPECT_EQ(c.load_function.total_ticks(), 320000u);
  EXPECT_EQ(c.load_function.expected_samples(), 32000u);
  const auto& scratch = c.load_function.segments()[2];
  EXPECT_EQ(scratch.start_tick, 80000u);
  EXPECT_TRUE(scratch.lateral.begin_continues);  // from the previous end, +2 µm
  EXPECT_FALSE(scratch.lateral.end_relative);
  EXPECT_DOUBLE_EQ(scratch.lateral.end, 10e-6);
  EXPECT_DOUBLE_EQ(scratch.normal.end, 1000e-6);
  EXPECT_TRUE(c.load_function.segments()[0].lateral.begin_from_measured);
}

TEST(ProtocolValidator, RejectsTwentyMilliNewtonsNamingSegmentFieldValueAndLimit) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(1)->mutable_normal()->set_end_un(20000);
  const ProtocolCheck c = check(p);
  const ValidationIssue* e = find(c, "segments[1].normal.end_uN");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("\"load\""), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("20000"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("10000"), std::string::npos) << e->message;
}

TEST(ProtocolValidator, RejectsALoadedScratchAcrossTheBreakpoint) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(2)->mutable_lateral()->set_end_um(-6);  // +2 -> -6 µm under load
  p.mutable_segments(3)->mutable_lateral()->set_end_um(-6);
  const ProtocolCheck c = check(p);
  const ValidationIssue* e = find(c, "segments[2].lateral");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("breakpoint"), std::string::npos);
}

TEST(ProtocolValidator, RejectsTravelBeyondTheTransducer) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(0)->mutable_lateral()->set_end_um(16);
  p.mutable_segments(1)->mutable_lateral()->set_end_um(16);
  EXPECT_NE(find(check(p), "segments[0].lateral.end_um"), nullptr);
}

TEST(ProtocolValidator, RejectsVelocityOutsideTheRange) {
  v1::Protocol fast = standard_protocol();
  fast.mutable_segments(2)->set_duration_s(0.05);  // 8 µm in 50 ms: 160 µm/s
  EXPECT_NE(find(check(fast), "segments[2].lateral.end_um"), nullptr);
  v1::Protocol slow = standard_protocol();
  slow.mutable_segments(2)->set_duration_s(100);  // 0.08 µm/s under load
  EXPECT_NE(find(check(slow), "segments[2].lateral.end_um"), nullptr);
}

TEST(ProtocolValidator, WarnsBelowPointTwoMicronsPerSecond) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(2)->set_duration_s(50);  // 0.16 µm/s
  const ProtocolCheck c = check(p);
  ASSERT_TRUE(c.ok()) << all(c);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("0.16"), std::string::npos) << c.warnings[0];
}

TEST(ProtocolValidator, RejectsADiscontinuousBegin) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(2)->mutable_lateral()->set_begin_um(3);
  EXPECT_NE(find(check(p), "segments[2].lateral.begin_um"), nullptr);
}

TEST(ProtocolValidator, RejectsDurationsThatAreNotWholeSamplePeriods) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(0)->set_duration_s(5.00005);  // half a loop period
  EXPECT_NE(find(check(p), "segments[0].duration_s"), nullptr);
  v1::Protocol q = standard_protocol();
  q.mutable_segments(0)->set_duration_s(5.0005);  // whole ticks, half a sample
  EXPECT_NE(find(check(q), "segments[0].duration_s"), nullptr);
  v1::Protocol r = standard_protocol();
  r.mutable_segments(0)->set_duration_s(0);
  EXPECT_NE(find(check(r), "segments[0].duration_s"), nullptr);
}

TEST(ProtocolValidator, RejectsAnUnknownMode) {
  v1::Protocol p = standard_protocol();
  p.mutable_segments(1)->mutable_normal()->set_mode(static_cast<v1::NormalMode>(7));
  EXPECT_NE(find(check(p), "segments[1].normal.mode"), nullptr);
}

TEST(ProtocolValidator, RejectsAnEmptyProtocol) {
  EXPECT_NE(find(check(v1::Protocol{}), "segments"), nullptr);
}

TEST(LoadFunction, InterpolatesLinearlyWithinSegments) {
  const ProtocolCheck c = check(standard_protocol());
  ASSERT_TRUE(c.ok());
  SegmentRunner runner(c.load_function);
  const MeasuredStart at_rest;
  TickSetpoints mid_scratch, last;
  for (std::uint64_t tick = 0; tick < 320000; ++tick) {
    const TickSetpoints sp = runner.at(tick, at_rest);
    if (tick == 0) {
      EXPECT_EQ(sp.segment, 0u);
      EXPECT_DOUBLE_EQ(sp.lateral, 0);
    }
    if (tick == 160000) mid_scratch = sp;  // t = 16 s
    last = sp;
  }
  EXPECT_EQ(mid_scratch.segment, 2u);
  EXPECT_NEAR(mid_scratch.lateral, 6e-6, 1e-15);
  EXPECT_NEAR(mid_scratch.normal, 1e-3, 1e-15);
  EXPECT_EQ(last.segment, 4u);
  EXPECT_NEAR(last.lateral, 10e-6 / 50000, 1e-15);
}

}  // namespace
}  // namespace tribo::daemon
