#include "daemon/protocol_validator.h"
#include "daemon/validation_messages.h"

#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include <numbers>

#include "proto/text_format_file.h"
#include "tests/daemon/protocol_check_support.h"
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

using tribo::testing::all;
using tribo::testing::find;

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

// A protocol from its text-format body.
v1::Protocol protocol(const std::string& text) {
  v1::Protocol p;
  if (!google::protobuf::TextFormat::ParseFromString(text, &p)) throw std::runtime_error("bad text");
  return p;
}

// Approach to +4 µm and load to 2000 µN, then `body`, then unload and return.
v1::Protocol loaded(const std::string& body) {
  return protocol(R"(
    name: "t"
    segments { name: "approach" duration_s: 2 normal { end_uN: 0 } lateral { end_um: 4 } }
    segments { name: "load" duration_s: 1 normal { end_uN: 2000 } lateral { shape: HOLD } }
  )" + body + R"(
    segments { name: "unload" duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
    segments { name: "return" duration_s: 2 normal { end_uN: 0 } lateral { end_um: 0 } }
  )");
}

TEST(ProtocolValidator, RepeatBlocksUnrollWithPerPassValuesAndAlternatingDirection) {
  const ProtocolCheck c = check(protocol(R"(
    name: "sweep"
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments {
      name: "loads"
      repeat {
        count: 2
        segments { name: "load" duration_s: 1 normal { } lateral { shape: HOLD }
                   per_pass { normal_end_uN: [1000, 3000] } }
        segments {
          name: "speeds"
          repeat {
            count: 3
            alternate_direction: true
            segments { name: "scratch" normal { shape: HOLD } lateral { delta_um: 6 }
                       per_pass { lateral_speed_um_per_s: [0.5, 2, 40] } }
          }
        }
        segments { name: "unload" duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
      }
    }
  )"));
  ASSERT_TRUE(c.ok()) << all(c);
  const auto& seg = c.load_function.segments();
  ASSERT_EQ(seg.size(), 1u + 2 * 5);
  EXPECT_EQ(seg[1].name, "load (pass 1/2)");
  EXPECT_EQ(seg[3].name, "scratch (pass 1/2, 2/3)");
  EXPECT_DOUBLE_EQ(seg[1].normal.end, 1000e-6);
  EXPECT_DOUBLE_EQ(seg[6].normal.end, 3000e-6);
  // 6 µm at 0.5, 2 and 40 µm/s: 12 s, 3 s, 0.15 s; every other pass backwards.
  EXPECT_EQ(seg[2].tick_count, 120000u);
  EXPECT_EQ(seg[3].tick_count, 30000u);
  EXPECT_EQ(seg[4].tick_count, 1500u);
  EXPECT_DOUBLE_EQ(seg[2].lateral.end, 6e-6);
  EXPECT_DOUBLE_EQ(seg[3].lateral.end, -6e-6);
  EXPECT_DOUBLE_EQ(seg[4].lateral.end, 6e-6);
  EXPECT_TRUE(seg[2].lateral.end_relative);
}

TEST(ProtocolValidator, PerPassListsMustMatchTheRepeatCount) {
  const ProtocolCheck c = check(protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { repeat { count: 3 segments { name: "rest" normal { } lateral { }
                                            per_pass { duration_s: [1, 2] } } } }
  )"));
  const ValidationIssue* e = find(c, "segments[1].repeat.segments[0].per_pass.duration_s");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("2 values"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("count 3"), std::string::npos) << e->message;

  const ProtocolCheck outside = check(protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } per_pass { duration_s: [1] } }
  )"));
  EXPECT_NE(find(outside, "segments[0].per_pass.duration_s"), nullptr) << all(outside);
}

TEST(ProtocolValidator, ARepeatBlockHoldsOnlyItsSegments) {
  const ProtocolCheck c = check(protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 2 } }
    segments { name: "block" duration_s: 3
               repeat { count: 2 segments { duration_s: 1 normal { } lateral { } } } }
  )"));
  EXPECT_NE(find(c, "segments[1]"), nullptr) << all(c);
  const ProtocolCheck zero = check(protocol(R"(
    segments { repeat { count: 0 segments { duration_s: 1 normal { } lateral { } } } }
  )"));
  EXPECT_NE(find(zero, "segments[0].repeat.count"), nullptr) << all(zero);
}

TEST(ProtocolValidator, ErrorsInARepeatNameThePass) {
  const ProtocolCheck c = check(loaded(R"(
    segments { repeat { count: 3 segments { name: "scratch" normal { shape: HOLD } lateral { delta_um: 2 }
                                            per_pass { lateral_speed_um_per_s: [1, 200, 1] } } } }
  )"));
  const ValidationIssue* e = find(c, "segments[2].repeat.segments[0].lateral.speed_um_per_s");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("\"scratch\" (pass 2/3)"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("200"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("100"), std::string::npos) << e->message;
}

// The repeated scratch moved across the breakpoint: every one of its eight
// passes breaks the same rule, and the message says it once with the passes
// listed (not eight times in one line).
TEST(ValidationMessages, ARuleBrokenInEveryPassIsSaidOnceWithThePasses) {
  v1::Protocol p;
  ASSERT_FALSE(wire::load_text_proto_file(std::string(TRIBO_SOURCE_DIR) + "/config/protocols/repeated_scratch.textproto", p));
  p.mutable_segments(0)->mutable_lateral()->set_end_um(-2);  // approach to -2 µm
  p.mutable_segments(1)->mutable_repeat()->mutable_segments(3)->mutable_lateral()->set_end_um(-2);  // "back"
  const ProtocolCheck c = check(p);
  ASSERT_EQ(c.errors.size(), 8u) << all(c);
  EXPECT_EQ(c.errors[3].segment, "segments[1].repeat.segments[1] \"scratch\"");
  EXPECT_EQ(c.errors[3].pass, "4/8");
  const std::string message = describe_issues(c.errors);
  const std::string rule = "keep loaded segments on one side of it";
  EXPECT_EQ(message,
            "segments[1].repeat.segments[1] \"scratch\" (passes 1-8 of 8): loaded lateral path [-2, 10] µm comes "
            "within 0.5 µm of the breakpoint at 0 µm; " + rule);
  const auto grouped = group_repeated_issues(c.errors);
  ASSERT_EQ(grouped.size(), 1u);
  EXPECT_EQ(grouped[0].field, "segments[1].repeat.segments[1].lateral");
}

// The same rule on the same field of different segments is said once with
// the segments listed; different rules stay apart.
TEST(ValidationMessages, TheSameRuleInSeveralSegmentsIsSaidOnce) {
  const std::vector<ValidationIssue> issues{
      {"segments[2].lateral", "segments[2] \"a\": too fast", "segments[2] \"a\"", ""},
      {"segments[3].normal.end_uN", "segments[3] \"b\": too heavy", "segments[3] \"b\"", ""},
      {"segments[5].lateral", "segments[5] \"c\": too fast", "segments[5] \"c\"", ""},
      {"segments[6].repeat.segments[0].lateral", "segments[6].repeat.segments[0] \"d\" (pass 2/4): too fast",
       "segments[6].repeat.segments[0] \"d\"", "2/4"},
      {"segments[6].repeat.segments[0].lateral", "segments[6].repeat.segments[0] \"d\" (pass 4/4): too fast",
       "segments[6].repeat.segments[0] \"d\"", "4/4"},
      {"segments", "the protocol lasts 1e+06 s", "", ""}};
  EXPECT_EQ(describe_issues(issues),
            "segments[2] \"a\", segments[5] \"c\", segments[6].repeat.segments[0] \"d\" (passes 2, 4 of 4): too fast "
            "(and 2 more: segments[3] \"b\": too heavy; the protocol lasts 1e+06 s;)");
  EXPECT_EQ(passes_text({"3/8"}), "(pass 3/8)");
  EXPECT_EQ(passes_text({"1/8", "2/8", "3/8", "5/8", "7/8", "8/8"}), "(passes 1-3, 5, 7, 8 of 8)");
  EXPECT_EQ(passes_text({"1/2, 1/3", "2/2, 1/3"}), "(passes 1/2, 1/3 and 2/2, 1/3)");
}

TEST(ProtocolValidator, SpeedSetsTheDurationInWholeSamplePeriods) {
  const ProtocolCheck c = check(loaded(R"(
    segments { name: "scratch" normal { shape: HOLD } lateral { end_um: 12 speed_um_per_s: 13.5 } }
  )"));
  ASSERT_TRUE(c.ok()) << all(c);
  EXPECT_EQ(c.load_function.segments()[2].tick_count, 5930u) << "8 µm / 13.5 µm/s = 0.5926 s -> 0.593 s";
  const ProtocolCheck both = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD } lateral { end_um: 12 speed_um_per_s: 4 } }
  )"));
  EXPECT_NE(find(both, "segments[2].duration_s"), nullptr) << all(both);
}

TEST(ProtocolValidator, GivesEndOrDeltaNotBoth) {
  const ProtocolCheck c = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD } lateral { end_um: 8 delta_um: 4 } }
  )"));
  EXPECT_NE(find(c, "segments[2].lateral.delta_um"), nullptr) << all(c);
}

TEST(ProtocolValidator, AHoldStaysAtItsBegin) {
  const ProtocolCheck c = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD end_uN: 3000 } lateral { shape: HOLD } }
  )"));
  EXPECT_NE(find(c, "segments[2].normal.end_uN"), nullptr) << all(c);
}

TEST(ProtocolValidator, SineSegmentsHoldWholeCyclesAndTheirExtremesCount) {
  const ProtocolCheck fraction = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: SINE sine { frequency_hz: 2.25 amplitude_um: 1 } } }
  )"));
  const ValidationIssue* e = find(fraction, "segments[2].lateral.sine.frequency_hz");
  ASSERT_NE(e, nullptr) << all(fraction);
  EXPECT_NE(e->message.find("4.5 cycles"), std::string::npos) << e->message;

  // About +4 µm, a 3.8 µm amplitude reaches +0.2 µm under load: the breakpoint.
  const ProtocolCheck deep = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: SINE sine { frequency_hz: 1 amplitude_um: 3.8 } } }
  )"));
  EXPECT_NE(find(deep, "segments[2].lateral"), nullptr) << all(deep);

  // 1 µm at 100 Hz: 400 m/s^2 of path acceleration.
  const ProtocolCheck hard = check(loaded(R"(
    segments { duration_s: 1 normal { shape: HOLD }
               lateral { shape: SINE sine { frequency_hz: 100 amplitude_um: 1 } } }
  )"));
  e = find(hard, "segments[2].lateral.end_um");
  ASSERT_NE(e, nullptr) << all(hard);
  EXPECT_NE(e->message.find("velocity"), std::string::npos) << e->message;  // 628 µm/s first

  const ProtocolCheck fine = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: SINE sine { frequency_hz: 2 amplitude_um: 1 end_amplitude_um: 3 } } }
  )"));
  EXPECT_TRUE(fine.ok()) << all(fine);
}

TEST(ProtocolValidator, VelocityProfileEndsWhereItsRatesTakeIt) {
  // From +4 µm: -4 µm/s rising to +4 µm/s over 2 s turns at +2 µm and ends at +4 µm.
  const ProtocolCheck c = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: VELOCITY_PROFILE velocity { begin_um_per_s: -4 end_um_per_s: 4 } } }
    segments { duration_s: 1 normal { shape: HOLD } lateral { begin_um: 4 end_um: 5 } }
  )"));
  ASSERT_TRUE(c.ok()) << all(c);
  // From +4 µm, -8 -> 0 µm/s ends at -4 µm: across the breakpoint under load.
  const ProtocolCheck cross = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: VELOCITY_PROFILE velocity { begin_um_per_s: -8 end_um_per_s: 0 } } }
  )"));
  EXPECT_NE(find(cross, "segments[2].lateral"), nullptr) << all(cross);
  const ProtocolCheck with_end = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { shape: VELOCITY_PROFILE end_um: 6 velocity { begin_um_per_s: 1 end_um_per_s: 1 } } }
  )"));
  EXPECT_NE(find(with_end, "segments[2].lateral.end_um"), nullptr) << all(with_end);
}

TEST(ProtocolValidator, FieldsMustBeInTheUnitOfTheMode) {
  const ProtocolCheck c = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { mode: LATERAL_FORCE end_um: 5 max_excursion_um: 1 } }
  )"));
  const ValidationIssue* e = find(c, "segments[2].lateral.end_um");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("µN"), std::string::npos) << e->message;
}

TEST(ProtocolValidator, LateralForceNeedsItsBreakAwayExcursionAndStaysInTheForceLimit) {
  const ProtocolCheck none = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD } lateral { mode: LATERAL_FORCE begin_uN: 0 end_uN: 500 } }
  )"));
  EXPECT_NE(find(none, "segments[2].lateral.max_excursion_um"), nullptr) << all(none);
  const ProtocolCheck strong = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { mode: LATERAL_FORCE begin_uN: 0 end_uN: 2500 max_excursion_um: 1 } }
  )"));
  EXPECT_NE(find(strong, "segments[2].lateral.end_uN"), nullptr) << all(strong);
  // The excursion bounds the position: from +4 µm, 4 µm of slip reaches the breakpoint.
  const ProtocolCheck far = check(loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { mode: LATERAL_FORCE begin_uN: 0 end_uN: -500 max_excursion_um: 4 } }
  )"));
  EXPECT_NE(find(far, "segments[2].lateral"), nullptr) << all(far);
}

TEST(ProtocolValidator, AChangeOfModeStartsFromTheMeasuredValue) {
  const ProtocolCheck c = check(loaded(R"(
    segments { duration_s: 2 normal { mode: NORMAL_CLOSED_LOOP_FORCE shape: HOLD }
               lateral { mode: LATERAL_FORCE begin_uN: 0 end_uN: 300 max_excursion_um: 1 } }
    segments { duration_s: 1 normal { shape: HOLD } lateral { shape: HOLD } }
  )"));
  ASSERT_TRUE(c.ok()) << all(c);
  const auto& seg = c.load_function.segments();
  EXPECT_EQ(seg[2].lateral_mode, LateralMode::kForce);
  EXPECT_FALSE(seg[2].lateral.begin_from_measured) << "begin_uN given";
  EXPECT_TRUE(seg[2].normal.begin_from_measured) << "open loop -> closed loop";
  EXPECT_TRUE(seg[3].lateral.begin_from_measured) << "force -> displacement";
  EXPECT_TRUE(seg[3].normal.begin_from_measured) << "closed loop -> open loop";
  EXPECT_TRUE(seg[4].lateral.begin_continues);
}

TEST(ProtocolValidator, PullInMarginAlongTheLateralPath) {
  // A lateral transducer with the normal axis's plates (85 µm, no bias): at
  // +13 µm a lateral force of 2000 µN, with 1 µm of break-away excursion,
  // needs a drive of 2000 µN + 116 N/m x 14 µm = 3.62 mN at a 71 µm gap:
  // 2F/g = 102 N/m leaves k_eff/k = 0.12.
  v1::DaemonConfig narrow = testing::default_config();
  v1::TransducerAxisConstants& lateral = *narrow.mutable_transducer()->mutable_lateral();
  lateral.set_gap_positive_m(85e-6);
  lateral.set_gap_negative_m(85e-6);
  lateral.set_bias_v(0);
  v1::Protocol p = loaded(R"(
    segments { duration_s: 2 normal { shape: HOLD } lateral { end_um: 13 } }
    segments { duration_s: 2 normal { shape: HOLD }
               lateral { mode: LATERAL_FORCE begin_uN: 0 end_uN: 2000 max_excursion_um: 1 } }
    segments { duration_s: 2 normal { shape: HOLD } lateral { end_um: 4 } }
  )");
  const ProtocolCheck c = validate_protocol(p, narrow);
  const ValidationIssue* e = find(c, "segments[3].lateral");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("pull-in margin"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("x = 14 µm"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("minimum 0.2"), std::string::npos) << e->message;
  // The shipped plates (120/126 µm, 100 V bias) leave k_eff/k ~ 0.35 there
  // (3.85 mN from the + plate at 106 µm against 0.23 mN of bias pull at 140 µm).
  EXPECT_TRUE(check(p).ok()) << all(check(p));
  p.mutable_segments(3)->mutable_lateral()->set_end_un(1000);  // 2.62 mN: k_eff/k = 0.36
  EXPECT_TRUE(validate_protocol(p, narrow).ok()) << all(validate_protocol(p, narrow));
}

TEST(ProtocolValidator, NormalDriveVoltageStaysBelowTheAmplifierLimit) {
  v1::DaemonConfig config = testing::default_config();
  config.mutable_transducer()->mutable_normal()->set_max_drive_v(300);  // 10 mN needs 404 V
  v1::Protocol p = standard_protocol();
  p.mutable_segments(1)->mutable_normal()->set_end_un(9000);
  p.mutable_segments(2)->mutable_normal()->set_end_un(9000);
  const ProtocolCheck c = validate_protocol(p, config);
  const ValidationIssue* e = find(c, "segments[1].normal.end_uN");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("300 V"), std::string::npos) << e->message;
  EXPECT_TRUE(check(p).ok()) << "600 V suffice";
}

TEST(ProtocolValidator, TheConfigMayAllowVelocitiesOutsideTheRange) {
  v1::DaemonConfig config = testing::default_config();
  config.mutable_limits()->set_allow_velocity_outside_range(true);
  v1::Protocol slow = standard_protocol();
  slow.mutable_segments(2)->set_duration_s(100);  // 0.08 µm/s under load
  const ProtocolCheck c = validate_protocol(slow, config);
  ASSERT_TRUE(c.ok()) << all(c);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("below the minimum 0.1"), std::string::npos) << c.warnings[0];
}

TEST(ProtocolValidator, TheUnrolledProtocolHasAMaximumSize) {
  const ProtocolCheck c = check(protocol(R"(
    segments { repeat { count: 1000 segments { repeat { count: 1000
      segments { duration_s: 0.001 normal { } lateral { } } } } } }
  )"));
  const ValidationIssue* e = find(c, "segments");
  ASSERT_NE(e, nullptr) << all(c);
  EXPECT_NE(e->message.find("100000"), std::string::npos) << e->message;
}

TEST(LoadFunction, SinesAndVelocityProfilesFollowTheirDefinitions) {
  AxisPath sine;
  sine.shape = Shape::kSine;
  sine.end_relative = true;
  sine.end = 2e-6;  // drifts 2 µm over the segment
  sine.sine_frequency_hz = 5;
  sine.sine_amplitude_begin = 1e-6;
  sine.sine_amplitude_end = 3e-6;
  const double end = path_end(sine, 4e-6, 2.0);
  EXPECT_DOUBLE_EQ(end, 6e-6);
  // A quarter period in (t = 0.05 s): the ramp plus the amplitude then (1.05 µm).
  EXPECT_NEAR(path_value(sine, 4e-6, end, 0.05, 2.0), 4.05e-6 + 1.05e-6, 1e-15);
  EXPECT_NEAR(path_value(sine, 4e-6, end, 2.0, 2.0), end, 1e-15) << "whole cycles: continuous";
  EXPECT_NEAR(path_rate(sine, 4e-6, end, 0.0, 2.0), 1e-6 + 2 * std::numbers::pi * 5 * 1e-6, 1e-15);

  AxisPath profile;
  profile.shape = Shape::kVelocityProfile;
  profile.rate_begin = 0;
  profile.rate_end = 4e-6;
  EXPECT_DOUBLE_EQ(path_end(profile, 1e-6, 2.0), 5e-6);
  EXPECT_NEAR(path_value(profile, 1e-6, 5e-6, 1.0, 2.0), 2e-6, 1e-18);
  EXPECT_NEAR(path_rate(profile, 1e-6, 5e-6, 1.0, 2.0), 2e-6, 1e-18);
}

TEST(LoadFunction, TheRunnerResolvesMeasuredBeginsAndChainsRelativeEnds) {
  const ProtocolCheck c = check(protocol(R"(
    segments { duration_s: 1 normal { end_uN: 0 } lateral { delta_um: 2 } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { delta_um: 1 } }
  )"));
  ASSERT_TRUE(c.ok()) << all(c);
  SegmentRunner runner(c.load_function);
  MeasuredStart measured;
  measured.lateral_position_m = 0.3e-6;  // where the instrument is
  TickSetpoints sp = runner.at(0, measured);
  EXPECT_DOUBLE_EQ(sp.lateral, 0.3e-6);
  EXPECT_TRUE(sp.segment_start);
  measured.lateral_position_m = 99;  // read only at a segment's first tick (and unused there)
  for (std::uint64_t t = 1; t < 10000; ++t) sp = runner.at(t, measured);
  EXPECT_FALSE(sp.segment_start);
  sp = runner.at(10000, measured);
  EXPECT_TRUE(sp.segment_start);
  EXPECT_NEAR(sp.lateral, 2.3e-6, 1e-15) << "continues from the actual end";
  for (std::uint64_t t = 10001; t < 20000; ++t) sp = runner.at(t, measured);
  EXPECT_NEAR(sp.lateral, 3.3e-6 - 1e-6 / 10000, 1e-15);
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
