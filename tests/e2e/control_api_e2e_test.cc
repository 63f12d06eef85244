// The control and safety API end to end: the real tribod on a
// loopback port, driven through the client library.
#include <gtest/gtest.h>

#include "client/tribo_client.h"
#include "proto/text_format_file.h"
#include "tests/e2e/e2e_support.h"
#include "tests/support/daemon_process.h"

namespace tribo {
namespace {

using testing::DaemonProcess;
using testing::TempDir;

// The standard scratch with a 50 min loaded dwell at +2 µm: still running
// whenever a request arrives.
v1::Protocol long_protocol() {
  v1::Protocol p;
  const auto e = wire::load_text_proto_file(
      std::string(TRIBO_SOURCE_DIR) + "/config/protocols/standard_scratch.textproto", p);
  if (e) throw std::runtime_error(*e);
  p.mutable_segments(2)->set_duration_s(3000);
  p.mutable_segments(2)->mutable_lateral()->set_end_um(2);
  p.mutable_segments(3)->mutable_lateral()->set_end_um(2);
  return p;
}

// Loads, subscribes, starts and waits until the run is past `time_s`.
void start_and_wait(client::TriboClient& client, double time_s) {
  v1::ClientMessage load, subscribe, start;
  *load.mutable_load_protocol()->mutable_protocol() = long_protocol();
  client.request(load);
  subscribe.mutable_subscribe();
  client.request(subscribe);
  start.mutable_start_run();
  client.request(start);
  for (;;) {
    const v1::ServerMessage event = client.next_event();
    ASSERT_FALSE(event.has_run_stop()) << "the run ended early";
    if (event.has_samples() && event.samples().time_s(event.samples().time_s_size() - 1) > time_s) return;
  }
}

v1::RunStop wait_for_stop(client::TriboClient& client) {
  for (;;) {
    const v1::ServerMessage event = client.next_event();
    if (event.has_run_stop()) return event.run_stop();
  }
}

v1::StatusReply status(client::TriboClient& client) {
  v1::ClientMessage m;
  m.mutable_get_status();
  return client.request(m).status();
}

TEST(ControlApi, GainsChangeWhileRunningAndStatusShowsTheTiming) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient client({"127.0.0.1", daemon.port()}, testing::controller_session());
  start_and_wait(client, 10);

  v1::ClientMessage set;
  set.mutable_set_gains()->set_loop(v1::LOOP_LATERAL_DISPLACEMENT);
  v1::PidGains& g = *set.mutable_set_gains()->mutable_gains();
  g.set_kp(2000);
  g.set_ki(7167);
  g.set_kd(5);
  g.set_derivative_filter_hz(1000);
  g.set_output_min(-0.005);
  g.set_output_max(0.005);
  const v1::SetGainsReply reply = client.request(set).set_gains();
  EXPECT_TRUE(reply.applied_to_running_run());
  v1::ClientMessage get;
  get.mutable_get_gains();
  EXPECT_EQ(client.request(get).get_gains().loops(0).gains().kp(), 2000);

  const v1::StatusReply running = status(client);
  EXPECT_EQ(running.state(), v1::RUNNING);
  EXPECT_EQ(running.stage_timings_size(), 6);
  EXPECT_GT(running.max_tick_us(), 0);
  EXPECT_GT(running.cycle_count(), 100000u);

  v1::ClientMessage abort;
  abort.mutable_abort_run()->set_reason("done");
  client.request(abort);
  EXPECT_EQ(wait_for_stop(client).exit_status(), v1::ABORT);
}

TEST(ControlApi, EmergencyStopLatchesAFaultUntilReArmed) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient client({"127.0.0.1", daemon.port()}, testing::controller_session());
  start_and_wait(client, 10);
  v1::ClientMessage stop;
  stop.mutable_emergency_stop()->set_reason("e2e");
  EXPECT_TRUE(client.request(stop).emergency_stop().run_was_active());
  const v1::RunStop run_stop = wait_for_stop(client);
  EXPECT_EQ(run_stop.exit_status(), v1::FAULT);
  EXPECT_EQ(run_stop.reason(), "emergency stop: e2e");

  const v1::StatusReply faulted = status(client);
  EXPECT_EQ(faulted.state(), v1::FAULTED);
  EXPECT_TRUE(faulted.tripped());
  EXPECT_EQ(faulted.trip_reason(), "emergency stop: e2e");
  EXPECT_GT(faulted.trip_time_s(), 10);

  v1::ClientMessage start;
  start.mutable_start_run();
  try {
    client.request(start);
    FAIL() << "started while faulted";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.error().code(), v1::WRONG_STATE);
    EXPECT_NE(e.error().message().find("re-arm"), std::string::npos) << e.what();
  }
  v1::ClientMessage rearm;
  rearm.mutable_rearm();
  const v1::RearmReply rearmed = client.request(rearm).rearm();
  // The continuing instrument (not a fresh session at rest):
  // unloaded, back near the neutral point where the stop sequence took it.
  const v1::DaemonConfig config = testing::default_config();
  EXPECT_NE(rearmed.lateral_position_m(), testing::reading_at_rest(config, config.sim().seed()).lateral_position_m);
  EXPECT_NEAR(rearmed.lateral_position_m(), 0, 0.5e-6);
  EXPECT_NEAR(rearmed.normal_force_n(), 0, 1e-6);
  EXPECT_EQ(status(client).state(), v1::ARMED);
}

TEST(ControlApi, AnyClientMayStopButOnlyTheControllerTunes) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient observer({"127.0.0.1", daemon.port()}, testing::observer_session());
  v1::ClientMessage tune;
  tune.mutable_autotune();
  try {
    observer.request(tune);
    FAIL() << "an observer tuned the loop";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.error().code(), v1::PERMISSION_DENIED);
  }
  v1::ClientMessage stop;
  stop.mutable_emergency_stop()->set_reason("observer");
  EXPECT_FALSE(observer.request(stop).emergency_stop().run_was_active());
  EXPECT_EQ(status(observer).state(), v1::FAULTED);
}

TEST(ControlApi, AutotuneReportsTheUltimateGainAndPeriod) {
  TempDir data;
  DaemonProcess daemon(data.path());
  client::TriboClient client({"127.0.0.1", daemon.port()}, testing::controller_session());
  v1::ClientMessage m;
  m.mutable_autotune();
  const v1::AutotuneReply r = client.request(m).autotune();
  EXPECT_GT(r.ultimate_gain_n_per_m(), 50);
  EXPECT_LT(r.ultimate_period_s(), 0.0185);  // above the 54 Hz resonance
  EXPECT_NEAR(r.proposed().kp(), 0.6 * r.ultimate_gain_n_per_m(), 1e-9);
  EXPECT_NE(r.rule().find("Ziegler-Nichols"), std::string::npos);
  EXPECT_FALSE(r.applied());
}

}  // namespace
}  // namespace tribo
