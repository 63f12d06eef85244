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
  TempDir data, cfg;
  v1::DaemonConfig config = default_config();
  config.mutable_server()->set_control_token("tok");
  DaemonProcess daemon(data.path(), write_config(cfg, config));
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};

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

}  // namespace
}  // namespace tribo::testing
