// Safety end to end, on the real tribod: the emergency stop gets through
// whatever else is going on (an autotune, silent connections), timeouts and
// the control lease free what a hung client holds, and an operator holding
// the control token can abort a run another session controls.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "tests/e2e/e2e_support.h"

namespace tribo {
namespace {

using testing::DaemonProcess;
using testing::RawClient;
using testing::TempDir;

v1::ClientMessage load_message(const v1::Protocol& p) {
  v1::ClientMessage m;
  *m.mutable_load_protocol()->mutable_protocol() = p;
  return m;
}

v1::ClientMessage estop_message(const std::string& reason) {
  v1::ClientMessage m;
  m.mutable_emergency_stop()->set_reason(reason);
  return m;
}

// A paced run of the standard scratch with a long loaded dwell.
v1::Protocol long_protocol() {
  v1::Protocol p = testing::standard_protocol();
  p.mutable_segments(2)->set_duration_s(3000);
  p.mutable_segments(2)->mutable_lateral()->set_end_um(2);
  p.mutable_segments(3)->mutable_lateral()->set_end_um(2);
  return p;
}

TEST(ApiSafety, AnEmergencyStopIsAnsweredWhileAutotuneRuns) {
  TempDir data;
  DaemonProcess daemon(data.path(), testing::write_config(data, testing::paced_config()));
  RawClient controller(daemon.port());
  ASSERT_TRUE(controller.request(testing::hello_message(v1::CONTROLLER)).has_hello());
  v1::ClientMessage tune;
  tune.set_request_id(77);
  tune.mutable_autotune();
  controller.send(tune);  // the paced experiment takes seconds
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  RawClient operator_(daemon.port());
  ASSERT_TRUE(operator_.request(testing::hello_message()).has_hello());
  const v1::ServerMessage stopped = operator_.request(estop_message("e2e during autotune"));
  ASSERT_TRUE(stopped.has_emergency_stop()) << stopped.DebugString();
  EXPECT_TRUE(stopped.emergency_stop().run_was_active());

  // The autotune's reply follows: stopped, no gains proposed.
  std::optional<v1::ServerMessage> reply;
  while ((reply = controller.read()) && reply->request_id() != 77) {
  }
  ASSERT_TRUE(reply);
  ASSERT_TRUE(reply->has_error()) << reply->DebugString();
  EXPECT_NE(reply->error().message().find("emergency stop"), std::string::npos) << reply->error().message();
  v1::ClientMessage status;
  status.mutable_get_status();
  EXPECT_EQ(operator_.request(status).status().state(), v1::FAULTED);
}

TEST(ApiSafety, TheRearmCheckRunsInTheLoopAndAnEmergencyStopEndsIt) {
  TempDir data;
  v1::DaemonConfig config = testing::paced_config();
  config.mutable_controller()->set_loop_rate_hz(100);  // the check's 64 ticks take 0.64 s
  config.mutable_controller()->set_default_acquisition_rate_hz(100);
  config.mutable_supervisor()->set_force_filter_hz(20);  // below the 100 Hz loop's Nyquist
  config.mutable_supervisor()->set_motion_filter_hz(20);
  // Gains a 100 Hz loop holds (daemon/loop_stability.h): integral action only
  // on the lateral plate (as the scorecard's slow loop), ki dt = 1 on the rest.
  auto* ctl = config.mutable_controller();
  ctl->mutable_lateral_displacement()->set_kp(0);
  ctl->mutable_lateral_displacement()->set_kd(0);
  ctl->mutable_lateral_displacement()->set_ki(500);
  ctl->mutable_lateral_force()->set_ki(100);
  ctl->mutable_normal_force()->set_ki(100);
  ctl->mutable_normal_displacement()->set_ki(1e4);
  DaemonProcess daemon(data.path(), testing::write_config(data, config));
  RawClient controller(daemon.port());
  ASSERT_TRUE(controller.request(testing::hello_message(v1::CONTROLLER)).has_hello());
  ASSERT_TRUE(controller.request(estop_message("e2e: latch first")).has_emergency_stop());
  v1::ClientMessage rearm;
  rearm.set_request_id(55);
  rearm.mutable_rearm();
  controller.send(rearm);

  // The daemon's I/O thread is not held by the check: another client sees it
  // running and its emergency stop is answered during it.
  RawClient operator_(daemon.port());
  ASSERT_TRUE(operator_.request(testing::hello_message()).has_hello());
  v1::ClientMessage status;
  status.mutable_get_status();
  bool seen = false;
  for (int i = 0; i < 5000 && !seen; ++i) {  // bounded: an I/O thread held by the check never shows it
    seen = operator_.request(status).status().activity() == "re-arm check";
    if (!seen) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(seen) << "the re-arm check was never seen running";
  const v1::ServerMessage stopped = operator_.request(estop_message("e2e during re-arm"));
  ASSERT_TRUE(stopped.has_emergency_stop()) << stopped.DebugString();

  std::optional<v1::ServerMessage> reply;
  while ((reply = controller.read()) && reply->request_id() != 55) {
  }
  ASSERT_TRUE(reply);
  ASSERT_TRUE(reply->has_error()) << "re-armed despite the emergency stop: " << reply->DebugString();
  EXPECT_NE(reply->error().message().find("emergency stop"), std::string::npos) << reply->error().message();
  const v1::StatusReply after = operator_.request(status).status();
  EXPECT_EQ(after.state(), v1::FAULTED);
  EXPECT_NE(after.trip_reason().find("e2e during re-arm"), std::string::npos) << after.trip_reason();
}

TEST(ApiSafety, SilentConnectionsDoNotLockOutTheEmergencyStop) {
  TempDir data;
  v1::DaemonConfig config = testing::default_config();
  config.mutable_server()->set_max_clients(4);
  DaemonProcess daemon(data.path(), testing::write_config(data, config));
  std::vector<std::unique_ptr<RawClient>> silent;
  for (int i = 0; i < 4; ++i) silent.push_back(std::make_unique<RawClient>(daemon.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  RawClient operator_(daemon.port());
  const v1::ServerMessage hello = operator_.request(testing::hello_message());
  ASSERT_TRUE(hello.has_hello()) << hello.DebugString();
  EXPECT_TRUE(operator_.request(estop_message("e2e")).has_emergency_stop());
}

TEST(ApiSafety, AConnectionWithoutHelloIsClosedAfterTheHandshakeTimeout) {
  TempDir data;
  v1::DaemonConfig config = testing::default_config();
  config.mutable_server()->set_handshake_timeout_s(0.5);
  DaemonProcess daemon(data.path(), testing::write_config(data, config));
  RawClient silent(daemon.port());
  // Half a frame: announces 1 MiB, sends a few bytes, then nothing.
  silent.send_bytes(std::string("\x80\x80\x40", 3) + "abc");
  EXPECT_TRUE(silent.closed_by_peer(10000));
}

TEST(ApiSafety, AHungControllerLosesControlWhenItsLeaseLapses) {
  TempDir data;
  v1::DaemonConfig config = testing::paced_config();
  config.mutable_server()->set_control_lease_s(1.0);
  DaemonProcess daemon(data.path(), testing::write_config(data, config));
  RawClient controller(daemon.port());
  ASSERT_TRUE(controller.request(testing::hello_message(v1::CONTROLLER)).has_hello());
  ASSERT_FALSE(controller.request(load_message(long_protocol())).has_error());
  v1::ClientMessage start;
  start.mutable_start_run();
  ASSERT_FALSE(controller.request(start).has_error());
  // The controller now hangs: connected, sending nothing.
  RawClient observer(daemon.port());
  ASSERT_TRUE(observer.request(testing::hello_message()).has_hello());
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe()->set_decimation(1000);
  ASSERT_TRUE(observer.request(subscribe).has_subscribe());
  const testing::StreamLog log = testing::read_until_stop(observer);
  ASSERT_TRUE(log.stop);
  EXPECT_EQ(log.stop->exit_status(), v1::ABORT);
  EXPECT_NE(log.stop->reason().find("lease"), std::string::npos) << log.stop->reason();
  // Control is free again.
  RawClient next(daemon.port());
  EXPECT_TRUE(next.request(testing::hello_message(v1::CONTROLLER)).has_hello());
}

TEST(ApiSafety, TheControlTokenAbortsARunAnotherSessionControls) {
  TempDir data;
  v1::DaemonConfig config = testing::paced_config();
  config.mutable_server()->set_control_token("e2e-secret");
  DaemonProcess daemon(data.path(), testing::write_config(data, config));
  RawClient controller(daemon.port());
  ASSERT_TRUE(controller.request(testing::hello_message(v1::CONTROLLER, "e2e-secret")).has_hello());
  ASSERT_FALSE(controller.request(load_message(long_protocol())).has_error());
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe()->set_decimation(1000);
  controller.request(subscribe);
  v1::ClientMessage start;
  start.mutable_start_run();
  ASSERT_FALSE(controller.request(start).has_error());

  RawClient operator_(daemon.port());
  ASSERT_TRUE(operator_.request(testing::hello_message()).has_hello());
  v1::ClientMessage abort;
  abort.mutable_abort_run()->set_reason("operator");
  EXPECT_EQ(operator_.request(abort).error().code(), v1::PERMISSION_DENIED);  // no token
  abort.mutable_abort_run()->set_token("wrong");
  EXPECT_EQ(operator_.request(abort).error().code(), v1::UNAUTHENTICATED);
  abort.mutable_abort_run()->set_token("e2e-secret");
  const v1::ServerMessage aborted = operator_.request(abort);
  ASSERT_TRUE(aborted.has_abort_run()) << aborted.DebugString();
  const testing::StreamLog log = testing::read_until_stop(controller);
  ASSERT_TRUE(log.stop);
  EXPECT_EQ(log.stop->exit_status(), v1::ABORT);
  EXPECT_EQ(log.stop->reason(), "operator");
}

TEST(ApiSafety, LongStringsAreRefusedAndTheListingStaysReadable) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient controller(daemon.port());
  ASSERT_TRUE(controller.request(testing::hello_message(v1::CONTROLLER)).has_hello());
  v1::Protocol p = testing::short_protocol();
  p.set_name(std::string(2 << 20, 'n'));
  const v1::ServerMessage refused = controller.request(load_message(p));
  ASSERT_TRUE(refused.has_error());
  EXPECT_EQ(refused.error().field(), "name");
  // An observer's 2.5 MB emergency stop reason still stops (the reason is cut).
  RawClient observer(daemon.port());
  ASSERT_TRUE(observer.request(testing::hello_message()).has_hello());
  const v1::ServerMessage stopped = observer.request(estop_message(std::string(2500000, 'r')));
  ASSERT_TRUE(stopped.has_emergency_stop()) << stopped.error().message();
  v1::ClientMessage status;
  status.mutable_get_status();
  const v1::StatusReply s = observer.request(status).status();
  EXPECT_EQ(s.state(), v1::FAULTED);
  EXPECT_LT(s.trip_reason().size(), 5000u);
  v1::ClientMessage list;
  list.mutable_list_runs();
  EXPECT_TRUE(observer.request(list).has_list_runs());
}

}  // namespace
}  // namespace tribo

namespace tribo {
namespace {

// Item 11: an unwritable data directory is refused at start-up, naming the field.
TEST(ApiSafety, AnUnwritableDataDirectoryIsRefusedAtStartUp) {
  const auto result = testing::run_command({testing::DaemonProcess::tribod_path(), "--config",
                                            testing::DaemonProcess::default_config_path(), "--data-dir",
                                            "/proc/tribo-no-such-dir", "--port", "0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("recorder.data_dir"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace tribo
