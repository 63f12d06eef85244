#include "daemon/instrument_service.h"

#include <gtest/gtest.h>

#include "proto/run_files.h"
#include "tests/daemon/service_test_support.h"

namespace tribo::daemon {
namespace {

using testing::ServiceFixture;

v1::Protocol standard_protocol() { return testing::load_protocol_file("standard_scratch.textproto"); }

TEST(InstrumentService, AbortUnloadsSafelyRetractsAndRecordsTheReason) {
  ServiceFixture f;
  f.sink.at_time_s = 12.0;  // mid-scratch, under 1000 µN
  f.sink.at_time = [&] { f.service->abort_run("test abort"); };
  f.start();
  // The standard scratch with a loaded hold after the scratch: the unpaced
  // loop runs ahead of the drain thread that asks for the abort, by up to a
  // queue (16.4 s at 1 kHz) plus the block the drain holds, and without the
  // hold it could finish the protocol first (seen under load: the run ended
  // SUCCESS). 40 s of hold keep the abort inside the loaded part.
  v1::Protocol protocol = standard_protocol();
  v1::Segment hold = protocol.segments(2);  // at 1000 µN, ends where the scratch ends: a hold
  hold.set_name("hold loaded");
  hold.set_duration_s(40);
  *protocol.add_segments() = hold;
  for (int i = protocol.segments_size() - 1; i > 3; --i) protocol.mutable_segments()->SwapElements(i, i - 1);
  ASSERT_EQ(protocol.segments(3).name(), "hold loaded");
  f.run(protocol);
  ASSERT_EQ(f.sink.stops.size(), 1u);
  const v1::RunStop& stop = f.sink.stops[0];
  EXPECT_EQ(stop.exit_status(), v1::ABORT);
  EXPECT_EQ(stop.reason(), "test abort");
  EXPECT_FALSE(f.sink.gaps);

  // Unload at 10 mN/s with the tip held, hold 50 ms, retract at 10 µm/s from ~4 µm.
  testing::expect_safe_sequence(f.sink.samples, f.config);
  const auto& b = f.sink.samples;
  EXPECT_GT(b.lateral_setpoint_m(testing::first_sample_with(b, v1::SAFE_UNLOAD) + 1), 3.9e-6);
  // 0.1 s unload, 0.05 s hold, 0.4-0.8 s retract (the abort lands somewhere
  // after 12 s: the loop runs ahead of the thread that asks), and the loop's
  // ramp lag (0.21 s x 10 µm/s) to settle.
  const double stopped_at = b.time_s(testing::first_sample_with(b, v1::SAFE_UNLOAD));
  EXPECT_GE(stopped_at, 12.0);
  EXPECT_LT(b.time_s(sample_count(b) - 1) - stopped_at, 2.0) << "unloaded and retracted within two seconds";
  EXPECT_EQ(testing::first_sample_with(b, v1::SAFETY_TRIPPED), -1) << "an abort is not a trip";

  // The recording holds the same samples and the stop document.
  std::string error;
  const auto recorded = wire::read_run_directory(f.dir.path() / stop.run_id(), error);
  ASSERT_TRUE(recorded) << error;
  EXPECT_EQ(recorded->metadata.stop().exit_status(), v1::ABORT);
  EXPECT_EQ(sample_count(recorded->samples), sample_count(b));
  EXPECT_EQ(stop.sample_count(), static_cast<std::uint64_t>(sample_count(b)));
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
}

TEST(InstrumentService, LateralForceTripFaultsTheRunAndBlocksRestart) {
  ServiceFixture f;
  // The scratch reads ~68 µN (friction ~94 µN less N tan 1.5° = 26 µN for the tilted tip).
  f.config.mutable_limits()->set_max_lateral_force_n(50e-6);
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
  // Loading a protocol does not clear the fault.
  v1::LoadProtocolReply loaded;
  EXPECT_FALSE(f.service->load_protocol(standard_protocol(), loaded));
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
  testing::expect_safe_sequence(f.sink.samples, f.config);
}

TEST(InstrumentService, RejectedProtocolMovesNothingAndRecordsNothing) {
  ServiceFixture f;
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

// After an emergency stop the instrument stays FAULTED until re-armed; the
// re-arm reports the measured state and the next run's setpoints start from
// the measured values, not from the protocol's nominal zero.
TEST(InstrumentService, RearmAfterAnEmergencyStopResyncsTheSetpointsToTheMeasuredValues) {
  ServiceFixture f;
  // The setpoints resync to the loop's reading; without the record's readout
  // noise (Table 3.2's 10 nm, after the loop) the recorded position is that reading.
  f.config.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(0);
  f.sink.at_time_s = 3;
  f.sink.at_time = [&] {
    v1::EmergencyStopReply reply;
    f.service->emergency_stop("", reply);
  };
  f.start();
  // A long loaded hold: the request from the sink's thread arrives during it.
  f.run(testing::parse_protocol(R"(
    name: "long"
    segments { duration_s: 2 normal { end_uN: 0 } lateral { end_um: 3 } }
    segments { duration_s: 1 normal { end_uN: 1000 } lateral { shape: HOLD } }
    segments { duration_s: 60 normal { shape: HOLD } lateral { shape: HOLD } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { shape: HOLD } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 0 } }
  )"));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].reason(), "emergency stop: requested by a client");
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);

  v1::RearmReply rearmed;
  ASSERT_FALSE(f.service->rearm(rearmed));
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
  // The re-arm reads the continuing instrument, not a fresh
  // session at rest: unloaded, the lateral axis back near the neutral point
  // where the stop sequence's retract took it (its loop still settling a
  // fraction of a µm away: 0.10 µm measured).
  const hal::SensorFrame at_rest = tribo::testing::reading_at_rest(f.config, f.config.sim().seed());
  EXPECT_NE(rearmed.lateral_position_m(), at_rest.lateral_position_m);
  EXPECT_NEAR(rearmed.lateral_position_m(), 0, 0.5e-6);
  EXPECT_NEAR(rearmed.normal_force_n(), 0, 1e-6);

  f.sink.clear();
  f.sink.at_time = nullptr;
  v1::LoadProtocolReply loaded;
  ASSERT_FALSE(f.service->load_protocol(testing::parse_protocol(R"(
    name: "short"
    acquisition_rate_hz: 10000
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 3 } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 0 } }
  )"), loaded));
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
  v1::StartRunReply started;
  ASSERT_FALSE(f.service->start_run(std::nullopt, started));
  f.service->wait_until_idle();
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].exit_status(), v1::SUCCESS) << f.sink.stops[0].reason();
  // At 10 kHz acquisition a sample is one tick: the first setpoint is the
  // first measured position (sensor noise, not 0), so nothing jumps.
  const auto& b = f.sink.samples;
  EXPECT_NE(b.lateral_position_m(0), 0.0);
  EXPECT_EQ(b.lateral_setpoint_m(0), b.lateral_position_m(0));
}

// An instrument that is not at the neutral point when the run starts (here
// its position reads 4 µm from the start): the first setpoint is the measured
// position, nothing jumps and nothing trips.
TEST(InstrumentService, ARunStartsFromWhereTheInstrumentIs) {
  ServiceFixture f;
  // The setpoint starts from the loop's reading; the record's readout noise
  // (Table 3.2's 10 nm, after the loop: tests/sim/record_noise_test.cc) is off
  // so that the recorded position is that reading.
  f.config.mutable_sim()->mutable_sensors()->set_lateral_position_record_noise_m(0);
  f.add_fault(v1::SENSOR_OFFSET, v1::CHANNEL_LATERAL_POSITION, 0, 0, 4e-6);
  f.start();
  f.run(testing::parse_protocol(R"(
    name: "away"
    acquisition_rate_hz: 10000
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 6 } }
    segments { duration_s: 1 normal { end_uN: 0 } lateral { end_um: 0 } }
  )"));
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].exit_status(), v1::SUCCESS) << f.sink.stops[0].reason();
  // Sample 0 is tick 0: the reading at rest plus the offset.
  const auto& b = f.sink.samples;
  EXPECT_EQ(b.lateral_position_m(0), tribo::testing::reading_at_rest(f.config, f.config.sim().seed()).lateral_position_m + 4e-6);
  EXPECT_EQ(b.lateral_setpoint_m(0), b.lateral_position_m(0));
}

TEST(InstrumentService, RearmRefusesWhileTheFaultPersists) {
  ServiceFixture f;
  f.add_fault(v1::SENSOR_NAN, v1::CHANNEL_LATERAL_FORCE, 0, 0);  // from the start, for good
  f.start();
  f.run(standard_protocol());
  ASSERT_EQ(f.sink.stops.size(), 1u);
  EXPECT_EQ(f.sink.stops[0].reason().rfind("sensor reading is not finite", 0), 0u) << f.sink.stops[0].reason();
  v1::RearmReply reply;
  const auto error = f.service->rearm(reply);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::WRONG_STATE);
  EXPECT_NE(error->message().find("not finite"), std::string::npos) << error->message();
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
}

TEST(InstrumentService, EmergencyStopWhileIdleLatchesAFault) {
  ServiceFixture f;
  f.start();
  v1::RearmReply rearm;
  EXPECT_TRUE(f.service->rearm(rearm)) << "nothing to re-arm";
  v1::EmergencyStopReply reply;
  ASSERT_FALSE(f.service->emergency_stop("cable check", reply));
  EXPECT_FALSE(reply.run_was_active());
  EXPECT_EQ(f.service->status().state(), v1::FAULTED);
  EXPECT_EQ(f.service->status().trip_reason(), "emergency stop: cable check");
  v1::LoadProtocolReply loaded;
  ASSERT_FALSE(f.service->load_protocol(standard_protocol(), loaded));
  v1::StartRunReply started;
  EXPECT_TRUE(f.service->start_run(std::nullopt, started));
  ASSERT_FALSE(f.service->rearm(rearm));
  EXPECT_EQ(f.service->status().state(), v1::ARMED);
}

TEST(InstrumentService, SetGainsIsValidatedAndRecordedInTheNextRun) {
  ServiceFixture f;
  f.start();
  v1::PidGains g = f.config.controller().lateral_displacement();
  g.set_kp(-1);
  v1::SetGainsReply reply;
  auto error = f.service->set_gains(v1::LOOP_LATERAL_DISPLACEMENT, g, reply);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code(), v1::INVALID_ARGUMENT);
  EXPECT_EQ(error->field(), "set_gains.gains.kp");
  EXPECT_NE(error->message().find("-1"), std::string::npos) << error->message();

  g.set_kp(1000);
  g.set_setpoint_weight_p(1);
  ASSERT_FALSE(f.service->set_gains(v1::LOOP_LATERAL_DISPLACEMENT, g, reply));
  EXPECT_FALSE(reply.applied_to_running_run());
  const v1::GetGainsReply all = f.service->gains();
  ASSERT_EQ(all.loops_size(), 4);
  EXPECT_EQ(all.loops(0).gains().kp(), 1000);
  f.run(standard_protocol());
  ASSERT_EQ(f.sink.starts.size(), 1u);
  EXPECT_EQ(f.sink.starts[0].lateral_gains().kp(), 1000);
  EXPECT_EQ(f.sink.starts[0].config().controller().lateral_displacement().setpoint_weight_p(), 1);
}

TEST(InstrumentService, TheRunStartListsTheUnrolledSegments) {
  ServiceFixture f;
  f.start();
  f.run(testing::load_protocol_file("velocity_reversal.textproto"));
  ASSERT_EQ(f.sink.starts.size(), 1u);
  const auto& segments = f.sink.starts[0].segments();
  ASSERT_EQ(segments.size(), 2 + 6 + 2);
  EXPECT_EQ(segments[3].name(), "stroke (pass 2/6)");
  EXPECT_DOUBLE_EQ(segments[3].start_s(), 7.0);
  EXPECT_DOUBLE_EQ(segments[3].duration_s(), 2.0);
  EXPECT_EQ(segments[3].lateral_mode(), v1::LATERAL_DISPLACEMENT);
  // The samples' segment_index refers to this list.
  const auto& b = f.sink.samples;
  for (int i = 0; i < sample_count(b); i += 97) {
    const auto& seg = segments[static_cast<int>(b.segment_index(i))];
    EXPECT_GE(b.time_s(i), seg.start_s());
    EXPECT_LT(b.time_s(i), seg.start_s() + seg.duration_s());
  }
}

TEST(InstrumentService, StatusReportsStageTimingAndTheCycleCounter) {
  ServiceFixture f;
  f.start();
  f.run(standard_protocol());
  const v1::StatusReply s = f.service->status();
  EXPECT_EQ(s.cycle_count(), 320000u);
  ASSERT_EQ(s.stage_timings_size(), 6);
  EXPECT_EQ(s.stage_timings(0).stage(), "read");
  EXPECT_EQ(s.stage_timings(5).stage(), "tick");
  for (const auto& t : s.stage_timings()) {
    EXPECT_GT(t.max_us(), 0) << t.stage();
    EXPECT_LE(t.mean_us(), t.max_us()) << t.stage();
  }
  EXPECT_EQ(s.max_tick_us(), s.stage_timings(5).max_us());
  EXPECT_EQ(s.overrun_count(), 0u);
  EXPECT_FALSE(s.tripped());
}

}  // namespace
}  // namespace tribo::daemon
