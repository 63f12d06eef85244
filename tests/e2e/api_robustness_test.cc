// The socket API against bad input and unauthorised clients: garbage,
// truncated, oversized and wrong-version frames, requests before the
// handshake, control commands from observers, wrong tokens, hostile run ids,
// a crash mid-run, and the bind policy.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <thread>

#include "daemon/api_server.h"
#include "proto/run_files.h"
#include "tests/e2e/e2e_support.h"

namespace tribo::testing {
namespace {

v1::ClientMessage with_body(const std::function<void(v1::ClientMessage&)>& fill) {
  v1::ClientMessage m;
  fill(m);
  return m;
}

// The daemon still serves a fresh client after whatever the test did.
void expect_daemon_serves(std::uint16_t port) {
  RawClient probe(port);
  const auto reply = probe.request(hello_message());
  EXPECT_TRUE(reply.has_hello()) << reply.DebugString();
}

TEST(ApiRobustness, RequestsBeforeHelloAreRefusedWithHandshakeRequired) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  const auto reply = c.request(with_body([](auto& m) { m.mutable_get_status(); }));
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().code(), v1::HANDSHAKE_REQUIRED);
  EXPECT_EQ(reply.error().field(), "hello");
  const auto hello = c.request(hello_message());
  ASSERT_TRUE(hello.has_hello());
  EXPECT_EQ(hello.hello().api_version(), 1u);
  EXPECT_EQ(hello.hello().role(), v1::OBSERVER);
  EXPECT_EQ(hello.hello().backend(), "sim");
  EXPECT_GT(hello.hello().capabilities_size(), 0);
  EXPECT_TRUE(c.request(with_body([](auto& m) { m.mutable_get_status(); })).has_status());
}

TEST(ApiRobustness, WrongVersionGetsATypedErrorAndTheConnectionClosed) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  const auto reply = c.request(hello_message(v1::OBSERVER, "", 2));
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().code(), v1::UNSUPPORTED_VERSION);
  EXPECT_EQ(reply.error().field(), "hello.api_version");
  EXPECT_NE(reply.error().message().find("version 1"), std::string::npos);
  EXPECT_TRUE(c.closed_by_peer());
  expect_daemon_serves(daemon.port());
}

TEST(ApiRobustness, GarbageFrameBodyIsAnErrorAndTheSessionGoesOn) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  c.send_bytes(std::string("\x05\xff\xff\xff\xff\xff", 6));  // a 5-byte frame of invalid protobuf
  const auto reply = c.read();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_EQ(reply->error().code(), v1::MALFORMED_REQUEST);
  EXPECT_TRUE(c.request(hello_message()).has_hello());
}

TEST(ApiRobustness, AnInvalidSizePrefixClosesTheConnection) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  c.send_bytes(std::string(10, '\xff'));  // a varint that never ends
  const auto reply = c.read();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_EQ(reply->error().code(), v1::MALFORMED_REQUEST);
  EXPECT_TRUE(c.closed_by_peer());
  expect_daemon_serves(daemon.port());
}

TEST(ApiRobustness, OversizedFrameIsRejectedFromItsHeaderAlone) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  c.send_bytes(std::string("\x80\x80\x80\x80\x04", 5));  // announces 1 GiB, sends none of it
  const auto reply = c.read();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_EQ(reply->error().code(), v1::MALFORMED_REQUEST);
  EXPECT_NE(reply->error().message().find("1073741824"), std::string::npos) << reply->error().message();
  EXPECT_NE(reply->error().message().find("4194304"), std::string::npos) << reply->error().message();
  EXPECT_TRUE(c.closed_by_peer());
  expect_daemon_serves(daemon.port());
}

TEST(ApiRobustness, TruncatedFrameThenHangUpLeavesTheDaemonServing) {
  TempDir data;
  DaemonProcess daemon(data.path());
  {
    RawClient c(daemon.port());
    std::string frame;
    wire::append_frame(hello_message(), 1 << 20, frame);
    c.send_bytes(frame.substr(0, frame.size() / 2));
  }
  {
    RawClient c(daemon.port());
    c.send_bytes(std::string("\x80", 1));  // half a size prefix
  }
  expect_daemon_serves(daemon.port());
}

TEST(ApiRobustness, ObserversCannotControlAndOnlyOneClientHoldsControl) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient observer(daemon.port());
  observer.request(hello_message());
  const v1::ClientMessage commands[] = {
      with_body([](auto& m) { *m.mutable_load_protocol()->mutable_protocol() = standard_protocol(); }),
      with_body([](auto& m) { m.mutable_start_run(); }),
  };
  for (const auto& command : commands) {
    const auto reply = observer.request(command);
    ASSERT_TRUE(reply.has_error()) << command.DebugString();
    EXPECT_EQ(reply.error().code(), v1::PERMISSION_DENIED);
    EXPECT_EQ(reply.error().field(), "role");
  }
  // An abort only stops a run: a daemon without a token takes it from an
  // observer too (here there is no run to abort).
  const auto abort = observer.request(with_body([](auto& m) { m.mutable_abort_run(); }));
  ASSERT_TRUE(abort.has_error());
  EXPECT_EQ(abort.error().code(), v1::WRONG_STATE);
  EXPECT_EQ(observer.request(with_body([](auto& m) { m.mutable_get_status(); })).status().state(), v1::IDLE);

  RawClient first(daemon.port());
  EXPECT_EQ(first.request(hello_message(v1::CONTROLLER)).hello().role(), v1::CONTROLLER);
  RawClient second(daemon.port());
  const auto refused = second.request(hello_message(v1::CONTROLLER));
  ASSERT_TRUE(refused.has_error());
  EXPECT_EQ(refused.error().code(), v1::PERMISSION_DENIED);
  EXPECT_EQ(refused.error().field(), "hello.role");
  const auto claimed = observer.request(with_body([](auto& m) { m.mutable_claim_control(); }));
  EXPECT_EQ(claimed.error().code(), v1::PERMISSION_DENIED);
  // Released control can be claimed by another session.
  EXPECT_TRUE(first.request(with_body([](auto& m) { m.mutable_release_control(); })).has_release_control());
  EXPECT_TRUE(observer.request(with_body([](auto& m) { m.mutable_claim_control(); })).has_claim_control());
  EXPECT_TRUE(observer.request(commands[0]).has_load_protocol());
}

TEST(ApiRobustness, ControlNeedsTheTokenFromTheEnvironmentOrConfig) {
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_control_token("from-config");
  config.mutable_server()->set_control_token_env("TRIBO_TEST_CONTROL_TOKEN");
  ::setenv("TRIBO_TEST_CONTROL_TOKEN", "from-env", 1);
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  ::unsetenv("TRIBO_TEST_CONTROL_TOKEN");
  for (const std::string token : {"", "from-config", "wrong"}) {
    RawClient c(daemon.port());
    const auto reply = c.request(hello_message(v1::CONTROLLER, token));
    ASSERT_TRUE(reply.has_error()) << token;
    EXPECT_EQ(reply.error().code(), v1::UNAUTHENTICATED) << token;
    EXPECT_EQ(reply.error().field(), "hello.token");
    // A failed hello leaves the session without a handshake.
    EXPECT_EQ(c.request(with_body([](auto& m) { m.mutable_get_status(); })).error().code(), v1::HANDSHAKE_REQUIRED);
  }
  RawClient c(daemon.port());
  EXPECT_EQ(c.request(hello_message(v1::CONTROLLER, "from-env")).hello().role(), v1::CONTROLLER);
}

TEST(ApiRobustness, HostileRunIdsAreRejectedAndUnknownOnesNotFound) {
  TempDir data;
  DaemonProcess daemon(data.path());
  RawClient c(daemon.port());
  c.request(hello_message());
  for (const std::string id : {"..", "../..", "/etc", "a/b", "", "."}) {
    const auto reply = c.request(with_body([&](auto& m) { m.mutable_fetch_samples()->set_run_id(id); }));
    ASSERT_TRUE(reply.has_error()) << id;
    EXPECT_EQ(reply.error().code(), v1::INVALID_ARGUMENT) << id;
    EXPECT_EQ(reply.error().field(), "fetch_samples.run_id");
  }
  const auto missing = c.request(with_body([](auto& m) { m.mutable_export_csv()->set_run_id("20990101-000000-000"); }));
  EXPECT_EQ(missing.error().code(), v1::NOT_FOUND);
  EXPECT_EQ(missing.error().field(), "export_csv.run_id");
}

TEST(ApiRobustness, TheNumberOfClientsIsBounded) {
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_max_clients(3);
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  // Full of clients that said hello: the next one is refused.
  RawClient a(daemon.port()), b(daemon.port()), c(daemon.port());
  for (RawClient* x : {&a, &b, &c}) EXPECT_TRUE(x->request(hello_message()).has_hello());
  RawClient d(daemon.port());
  const auto refusal = d.read();
  ASSERT_TRUE(refusal && refusal->has_error());
  EXPECT_EQ(refusal->error().field(), "server.max_clients");
  EXPECT_TRUE(d.closed_by_peer());
  // A connection that has not said hello makes room for a new one (silent
  // sockets must not lock out an emergency stop).
  b.close();
  RawClient silent(daemon.port());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  RawClient e(daemon.port());
  EXPECT_TRUE(e.request(hello_message()).has_hello());
  EXPECT_TRUE(silent.closed_by_peer());
}

// A kill -9 mid-run: the recording reads back up to its last flushed block,
// every row whole, and the run lists as incomplete.
TEST(ApiRobustness, ACrashMidRunLeavesAReadableRecording) {
  TempDir data, cfg;
  DaemonProcess daemon(data.path(), write_config(cfg, paced_config()));
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  v1::ClientMessage load, start, status;
  *load.mutable_load_protocol()->mutable_protocol() = short_protocol();
  controller.request(load);
  start.mutable_start_run();
  const std::string run_id = controller.request(start).start_run().run_id();
  status.mutable_get_status();
  while (controller.request(status).status().samples_recorded() < 500) std::this_thread::yield();
  daemon.kill_hard();

  std::string error;
  const auto run = wire::read_run_directory(data.path() / run_id, error);
  ASSERT_TRUE(run) << error;
  EXPECT_FALSE(run->metadata.has_stop());
  EXPECT_EQ(run->metadata.start().run_id(), run_id);
  EXPECT_EQ(run->metadata.run_descriptor().channels_size(), 9);
  const int n = sample_count(run->samples);
  EXPECT_GE(n, 500);
  EXPECT_LT(n, 3000);
  for (int i = 0; i < n; ++i) ASSERT_NEAR(run->samples.time_s(i), i * 1e-3 + 0.45e-3, 1e-9) << i;
  const auto listed = wire::list_recorded_runs(data.path());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_FALSE(listed[0].finalized());
  EXPECT_EQ(listed[0].sample_count(), static_cast<std::uint64_t>(n));
}

TEST(ApiRobustness, BindingBeyondLoopbackNeedsAToken) {
  TempDir data;
  const auto refused = run_command({DaemonProcess::tribod_path(), "--config", DaemonProcess::default_config_path(),
                                    "--bind", "0.0.0.0", "--port", "0", "--data-dir", data.path().string()});
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("server.bind_address = \"0.0.0.0\" is not a loopback address"), std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("TRIBOD_CONTROL_TOKEN"), std::string::npos) << refused.err;

  v1::ServerConfig server;
  server.set_bind_address("192.0.2.7");
  EXPECT_TRUE(daemon::check_bind_policy(server, ""));
  EXPECT_FALSE(daemon::check_bind_policy(server, "a-token"));
  server.set_bind_address("::");
  EXPECT_TRUE(daemon::check_bind_policy(server, ""));
  for (const char* loopback : {"127.0.0.1", "127.0.0.2", "::1"}) {
    server.set_bind_address(loopback);
    EXPECT_FALSE(daemon::check_bind_policy(server, "")) << loopback;
  }
}

}  // namespace
}  // namespace tribo::testing
