// What tribo tells the user about a run: the summary says what happened
// (measured velocity, steady state or why not, oscillations on their own),
// the live line fits an 80-column terminal, repeated issues are said once,
// protobuf's syntax errors come with a hint.
#include <gtest/gtest.h>

#include <cmath>

#include "client/run_progress.h"
#include "client/run_summary.h"
#include "client/user_messages.h"

namespace tribo::client {
namespace {

constexpr double kRateHz = 1000;

void add(v1::SampleBlock& b, double t, std::uint32_t segment, double setpoint_m, double position_m, double force_n) {
  b.add_time_s(t);
  b.add_segment_index(segment);
  b.add_normal_setpoint_n(1e-3);
  b.add_normal_force_n(1e-3);
  b.add_normal_displacement_m(0);
  b.add_lateral_setpoint_m(setpoint_m);
  b.add_lateral_position_m(position_m);
  b.add_lateral_force_n(force_n);
  b.add_status_flags(0);
}

// Three loaded segments: a 20 µm/s pass on which the tip only reaches
// 15.6 µm/s; a 10 µm/s pass it follows; a 5 Hz, 1 µm sine the tip follows
// with 0.8 µm and 0.3 rad lag, the force leading the position by 0.5 rad.
RunResult synthetic_run() {
  RunResult run;
  run.start.set_run_id("synthetic");
  run.start.set_loop_rate_hz(kRateHz);
  for (const char* name : {"fast pass", "slow pass", "wiggle"}) run.start.add_segments()->set_name(name);
  run.stop.set_exit_status(v1::SUCCESS);
  v1::SampleBlock& b = run.samples;
  double t = 0;
  for (int i = 0; i < 400; ++i, t += 1 / kRateHz) add(b, t, 0, 20e-6 * (i / kRateHz), 15.6e-6 * (i / kRateHz), 150e-6);
  const double x0 = b.lateral_setpoint_m(b.time_s_size() - 1);
  for (int i = 0; i < 400; ++i, t += 1 / kRateHz) {
    const double sp = x0 + 10e-6 * (i / kRateHz);
    add(b, t, 1, sp, sp - 0.1e-6, 140e-6);
  }
  const double x1 = b.lateral_setpoint_m(b.time_s_size() - 1);
  for (int i = 0; i < 1000; ++i, t += 1 / kRateHz) {
    const double w = 2 * M_PI * 5, s = i / kRateHz;
    add(b, t, 2, x1 + 1e-6 * std::sin(w * s), x1 + 0.8e-6 * std::sin(w * s - 0.3), 100e-6 * std::sin(w * s + 0.2));
  }
  return run;
}

TEST(RunSummary, SaysWhatTheTipDidAndWhetherItWasSteady) {
  const v1::RunSummary s = summarize_run(synthetic_run());
  ASSERT_EQ(s.scratches_size(), 2) << s.DebugString();  // the sine is not a scratch
  const auto& fast = s.scratches(0);
  EXPECT_NEAR(fast.velocity_um_s(), 20.0, 0.1);
  EXPECT_NEAR(fast.measured_velocity_um_s(), 15.6, 0.01);
  EXPECT_NEAR(fast.measured_travel_um(), 15.6 * 0.399, 0.01);
  EXPECT_FALSE(fast.steady_state());
  EXPECT_NE(fast.not_steady_reason().find("15.600 µm/s"), std::string::npos) << fast.not_steady_reason();
  const auto& slow = s.scratches(1);
  EXPECT_NEAR(slow.measured_velocity_um_s(), 10.0, 0.01);
  EXPECT_TRUE(slow.steady_state()) << slow.not_steady_reason();
  EXPECT_FALSE(slow.stiction_peak_found());  // constant friction: no peak

  const std::string text = summary_text(s);
  EXPECT_NE(text.find("steady state   NOT reached"), std::string::npos) << text;
  EXPECT_NE(text.find("segment 1/3 \"fast pass\""), std::string::npos) << text;
  EXPECT_NE(text.find("stiction peak  none"), std::string::npos) << text;
}

TEST(RunSummary, ReportsAnOscillationByAmplitudeAndPhase) {
  const v1::RunSummary s = summarize_run(synthetic_run());
  ASSERT_EQ(s.oscillations_size(), 1);
  const auto& o = s.oscillations(0);
  EXPECT_EQ(o.segment(), 2u);
  EXPECT_EQ(o.segment_name(), "wiggle");
  EXPECT_NEAR(o.frequency_hz(), 5.0, 1e-9);
  EXPECT_EQ(o.cycles(), 5);
  EXPECT_NEAR(o.setpoint_amplitude_um(), 1.0, 1e-3);
  EXPECT_NEAR(o.position_amplitude_um(), 0.8, 1e-3);
  EXPECT_NEAR(o.position_phase_deg(), -0.3 * 180 / M_PI, 0.1);
  EXPECT_NEAR(o.force_amplitude_un(), 100.0, 0.1);
  EXPECT_NEAR(o.force_phase_deg(), 0.5 * 180 / M_PI, 0.1);
  EXPECT_NE(summary_text(s).find("oscillation 5 Hz x 5 cycles"), std::string::npos) << summary_text(s);
}

std::size_t columns(const std::string& text) {
  std::size_t n = 0;
  for (unsigned char c : text) n += (c & 0xC0) != 0x80;
  return n;
}

TEST(RunProgress, TheLineFitsAnEightyColumnTerminal) {
  RunProgress progress(nullptr);
  v1::ServerMessage d;
  auto* descriptor = d.mutable_run_descriptor();
  descriptor->set_duration_s(99999.9);
  for (int i = 0; i < 120; ++i) descriptor->add_segment_names("scratch (pass " + std::to_string(i) + "/120)");
  progress.on_document(d);
  v1::ServerMessage e;
  e.mutable_segment_event()->set_segment_index(118);
  e.mutable_segment_event()->set_segment_name("a very long segment name (pass 119/120)");
  progress.on_document(e);
  v1::ServerMessage gap;
  gap.mutable_gap()->set_first_sequence(0);
  gap.mutable_gap()->set_end_sequence(10);
  progress.on_document(gap);
  const std::string line = progress.line();
  EXPECT_LE(columns(line), 79u) << line;
  EXPECT_NE(line.find("seg 119/120"), std::string::npos) << line;  // counted from 1, as the summary
}

TEST(UserMessages, AnIssueRepeatedForEveryPassIsSaidOnce) {
  const std::vector<std::string> warnings{
      "segments[1].repeat.segments[0] \"scratch\" (pass 1/3): loaded lateral velocity 0.1 µm/s below 0.2 µm/s",
      "segments[1].repeat.segments[0] \"scratch\" (pass 2/3): loaded lateral velocity 0.1 µm/s below 0.2 µm/s",
      "other",
      "segments[1].repeat.segments[0] \"scratch\" (pass 3/3): loaded lateral velocity 0.1 µm/s below 0.2 µm/s"};
  const auto collapsed = collapse_repeated(warnings);
  ASSERT_EQ(collapsed.size(), 2u);
  EXPECT_EQ(collapsed[0],
            "segments[1].repeat.segments[0] \"scratch\" (passes 1-3 of 3): loaded lateral velocity 0.1 µm/s below "
            "0.2 µm/s");
  EXPECT_EQ(collapsed[1], "other");
}

TEST(UserMessages, AMissingSpeedIsSaidAsSuch) {
  const std::string said = explain_missing_duration(
      "segments[2] \"scratch\": duration_s = 0 s must be in (0, 3600] s (and 1 more: x;)");
  EXPECT_NE(said.find("no duration_s and no lateral.speed_um_per_s given"), std::string::npos) << said;
  EXPECT_EQ(explain_missing_duration("duration_s = 5 s is long"), "duration_s = 5 s is long");
}

TEST(UserMessages, AnUnclosedBlockGetsAHint) {
  const std::string hinted = with_syntax_hint("p.textproto:44:1: Expected identifier, got: ");
  EXPECT_NE(hinted.find("hint: the file ended inside a block"), std::string::npos) << hinted;
  EXPECT_NE(with_syntax_hint("p.textproto:3:5: Message type \"tribo.v1.Segment\" has no field named \"nme\".")
                .find("misspelt"),
            std::string::npos);
}

}  // namespace
}  // namespace tribo::client
