// The tribo CLI's commands, their --json output and exit codes.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <thread>

#include <google/protobuf/util/json_util.h>

#include "proto/run_files.h"
#include "tests/e2e/e2e_support.h"
#include "tribo/v1/summary.pb.h"

namespace tribo::testing {
namespace {

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

template <typename Message>
Message parse_json(const std::string& json) {
  Message m;
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(json, &m).ok()) << json;
  return m;
}

struct Cli {
  std::string address;
  CommandResult operator()(std::vector<std::string> args) const {
    args.insert(args.begin(), DaemonProcess::tribo_cli_path());
    args.push_back("--address");
    args.push_back(address);
    return run_command(args);
  }
};

v1::DaemonConfig config_with_token(const std::string& token) {
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_control_token(token);
  return config;
}

// A daemon that gives control only with the token "tok", and the CLI for it.
struct GuardedDaemon {
  TempDir data, cfg;
  DaemonProcess daemon{data.path(), write_config(cfg, config_with_token("tok"))};
  Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
};

TEST(TriboCli, StatusListFetchAndExportAgreeWithTheRecording) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto ran = tribo({"run", kStandardProtocolPath, "--json", "--seed", "5"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const auto summary = parse_json<v1::RunSummary>(ran.out);
  const std::string run_id = summary.run_id();
  ASSERT_FALSE(run_id.empty());

  const auto status = tribo({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  const auto s = parse_json<v1::StatusReply>(status.out);
  EXPECT_EQ(s.state(), v1::ARMED);
  EXPECT_EQ(s.run_id(), run_id);
  EXPECT_EQ(s.samples_recorded(), 32000u);
  EXPECT_EQ(s.samples_dropped(), 0u);
  EXPECT_TRUE(s.backend_health().healthy());
  const auto status_text = tribo({"status"});
  EXPECT_NE(status_text.out.find("state      ARMED"), std::string::npos) << status_text.out;

  const auto list = tribo({"list", "--json"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  const auto runs = parse_json<v1::ListRunsReply>(list.out);
  ASSERT_EQ(runs.runs_size(), 1);
  EXPECT_EQ(runs.runs(0).run_id(), run_id);
  EXPECT_EQ(runs.runs(0).exit_status(), v1::SUCCESS);
  EXPECT_EQ(runs.runs(0).sample_count(), 32000u);
  EXPECT_TRUE(runs.runs(0).finalized());
  EXPECT_NE(tribo({"list"}).out.find(run_id + "    SUCCESS"), std::string::npos);

  const auto fetched_dir = out.path() / "fetched";
  const auto fetch = tribo({"fetch", run_id, "--out", fetched_dir.string(), "--json"});
  ASSERT_EQ(fetch.exit_code, 0) << fetch.err;
  const auto saved = parse_json<v1::SavedRun>(fetch.out);
  EXPECT_EQ(saved.sample_count(), 32000u);
  EXPECT_EQ(saved.exit_status(), "SUCCESS");
  const std::string recorded_csv = slurp(data.path() / run_id / wire::kSamplesFile);
  EXPECT_TRUE(slurp(fetched_dir / wire::kSamplesFile) == recorded_csv);

  const auto exported = tribo({"export", run_id});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  EXPECT_TRUE(exported.out == recorded_csv) << exported.out.size() << " vs " << recorded_csv.size();
  const auto to_file = tribo({"export", run_id, "--out", (out.path() / "x.csv").string(), "--json"});
  ASSERT_EQ(to_file.exit_code, 0) << to_file.err;
  EXPECT_EQ(parse_json<v1::SavedRun>(to_file.out).sample_count(), 32000u);
  EXPECT_TRUE(slurp(out.path() / "x.csv") == recorded_csv);
}

TEST(TriboCli, ExitCodesSayWhatWentWrong) {
  const GuardedDaemon guarded;
  const Cli& tribo = guarded.tribo;

  const auto no_token = tribo({"run", kStandardProtocolPath});
  EXPECT_EQ(no_token.exit_code, 4) << no_token.err;
  EXPECT_NE(no_token.err.find("hello.token"), std::string::npos) << no_token.err;

  const auto no_run = tribo({"abort", "--token", "tok", "--json"});
  EXPECT_EQ(no_run.exit_code, 5) << no_run.err;
  EXPECT_NE(no_run.out.find("\"code\": \"WRONG_STATE\""), std::string::npos) << no_run.out;

  EXPECT_EQ(tribo({"fetch", "20990101-000000-000"}).exit_code, 6);
  EXPECT_EQ(tribo({"export", "../x"}).exit_code, 2);
  EXPECT_EQ(tribo({"bogus"}).exit_code, 2);
  EXPECT_EQ(run_command({DaemonProcess::tribo_cli_path(), "status", "--address", "127.0.0.1:1"}).exit_code, 3);
}

TEST(TriboCli, AbortStopsARunningProtocol) {
  TempDir data, cfg;
  DaemonProcess daemon(data.path(), write_config(cfg, paced_config()));
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  client::TriboClient observer({"127.0.0.1", daemon.port()}, observer_session());
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  observer.request(subscribe);
  // The CLI's own run, in the background: it holds control, so abort is refused...
  const auto protocol_file = cfg.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  std::thread runner([&] { tribo({"run", protocol_file.string()}); });
  while (!observer.next_event().has_samples()) {
  }
  const auto refused = tribo({"abort"});
  EXPECT_EQ(refused.exit_code, 4) << refused.err;
  runner.join();
  // ...and a run started by a client that then releases control can be
  // aborted from the CLI.
  client::TriboClient controller({"127.0.0.1", daemon.port()}, controller_session());
  v1::ClientMessage load, start, release;
  *load.mutable_load_protocol()->mutable_protocol() = short_protocol();
  controller.request(load);
  start.mutable_start_run();
  controller.request(start);
  release.mutable_release_control();
  controller.request(release);
  const auto aborted = tribo({"abort", "--reason", "operator says stop"});
  EXPECT_EQ(aborted.exit_code, 0) << aborted.err;
  for (;;) {
    const auto event = observer.next_event();
    if (event.has_run_stop() && event.run_stop().exit_status() != v1::SUCCESS) {
      EXPECT_EQ(event.run_stop().exit_status(), v1::ABORT);
      EXPECT_EQ(event.run_stop().reason(), "operator says stop");
      break;
    }
  }
}

v1::GetGainsReply gains_json(const Cli& tribo) {
  const auto r = tribo({"gains", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return parse_json<v1::GetGainsReply>(r.out);
}

TEST(TriboCli, SetGainsChangesOnlyTheGivenGain) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const v1::GetGainsReply before = gains_json(tribo);
  ASSERT_EQ(before.loops_size(), 4);
  ASSERT_EQ(before.loops(0).loop(), v1::LOOP_LATERAL_DISPLACEMENT);
  ASSERT_NE(before.loops(0).gains().kd(), 7.5);

  const auto set = tribo({"set-gains", "--loop", "lateral-displacement", "--kd", "7.5", "--json"});
  ASSERT_EQ(set.exit_code, 0) << set.err;
  const auto applied = parse_json<v1::SetGainsReply>(set.out);
  EXPECT_EQ(applied.loop(), v1::LOOP_LATERAL_DISPLACEMENT);
  EXPECT_EQ(applied.gains().kd(), 7.5);

  v1::GetGainsReply expected = before;
  expected.mutable_loops(0)->mutable_gains()->set_kd(7.5);
  const v1::GetGainsReply after = gains_json(tribo);
  EXPECT_EQ(after.SerializeAsString(), expected.SerializeAsString()) << after.DebugString();

  // Text: units stated, and --loop picks one loop.
  const auto text = tribo({"gains", "--loop", "lateral-force"});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("lateral-force"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("1/s"), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("lateral-displacement"), std::string::npos) << text.out;
  const auto set_text = tribo({"set-gains", "--loop", "LOOP_NORMAL_FORCE", "--ki", "900"});
  ASSERT_EQ(set_text.exit_code, 0) << set_text.err;
  EXPECT_NE(set_text.out.find("ki                    900 1/s"), std::string::npos) << set_text.out;
}

TEST(TriboCli, SetGainsRejectsBadValuesNamingTheField) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const v1::GetGainsReply before = gains_json(tribo);
  struct Case {
    std::vector<std::string> args;
    std::string named;
  };
  const std::vector<Case> cases{
      {{"--loop", "lateral-displacement", "--kp", "-1"}, "set_gains.gains.kp"},  // the daemon's limit
      {{"--loop", "lateral-displacement", "--ki", "nan"}, "--ki nan"},
      {{"--loop", "lateral-displacement", "--kd", "abc"}, "--kd abc is not a number"},
      {{"--loop", "lateral-displacement", "--output-max", "1e"}, "--output-max"},
      {{"--loop", "sideways", "--kp", "1"}, "--loop sideways is not a control loop"},
      {{"--kp", "1"}, "--loop is required"},
      {{"--loop", "lateral-displacement", "--kq", "1"}, "unknown option --kq"},
      {{"--loop", "lateral-displacement", "--kp"}, "--kp needs a value"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args{"set-gains"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = tribo(args);
    EXPECT_EQ(r.exit_code, 2) << c.named << ": " << r.err;
    EXPECT_NE(r.err.find(c.named), std::string::npos) << r.err;
  }
  EXPECT_EQ(gains_json(tribo).SerializeAsString(), before.SerializeAsString());
}

TEST(TriboCli, RearmAfterAnEmergencyStopLetsARunStartAgain) {
  const GuardedDaemon guarded;
  const Cli& tribo = guarded.tribo;
  const auto protocol_file = guarded.cfg.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());

  const auto stop = tribo({"estop", "--reason", "drill", "--json"});  // any client may stop
  ASSERT_EQ(stop.exit_code, 0) << stop.err;
  EXPECT_FALSE(parse_json<v1::EmergencyStopReply>(stop.out).run_was_active());
  EXPECT_EQ(parse_json<v1::StatusReply>(tribo({"status", "--json"}).out).state(), v1::FAULTED);

  const auto refused = tribo({"run", protocol_file.string(), "--token", "tok"});
  EXPECT_EQ(refused.exit_code, 5) << refused.err;
  EXPECT_NE(refused.err.find("re-arm"), std::string::npos) << refused.err;
  EXPECT_EQ(tribo({"rearm"}).exit_code, 4);  // control needs the token
  EXPECT_EQ(tribo({"set-gains", "--loop", "lateral-force", "--ki", "1"}).exit_code, 4);

  const auto rearmed = tribo({"rearm", "--token", "tok"});
  ASSERT_EQ(rearmed.exit_code, 0) << rearmed.err;
  EXPECT_NE(rearmed.out.find("re-armed"), std::string::npos) << rearmed.out;
  const auto ran = tribo({"run", protocol_file.string(), "--token", "tok", "--json"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  EXPECT_EQ(parse_json<v1::RunSummary>(ran.out).exit_status(), "SUCCESS");
}

TEST(TriboCli, AutotuneAppliesTheProposedGainsOnRequest) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto bad = tribo({"autotune", "--relay-amplitude-n", "big"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--relay-amplitude-n big"), std::string::npos) << bad.err;
  const auto tuned = tribo({"autotune", "--apply", "--json"});
  ASSERT_EQ(tuned.exit_code, 0) << tuned.err;
  const auto reply = parse_json<v1::AutotuneReply>(tuned.out);
  EXPECT_TRUE(reply.applied());
  EXPECT_GT(reply.ultimate_gain_n_per_m(), 0);
  EXPECT_EQ(gains_json(tribo).loops(0).gains().kp(), reply.proposed().kp());
}

}  // namespace
}  // namespace tribo::testing
