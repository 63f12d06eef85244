// The tribo CLI's commands, their --json output and exit codes.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <google/protobuf/util/json_util.h>

#include "proto/run_files.h"
#include "proto/text_format_file.h"
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
  // The CLI's own run, in the background...
  const auto protocol_file = cfg.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  std::thread runner([&] { tribo({"run", protocol_file.string()}); });
  while (!observer.next_event().has_samples()) {
  }
  // Whether a second client may abort without a token on a daemon without
  // one is the daemon's policy (AbortFromAnotherTerminalStopsTheCliRun has
  // the token case); here the run just ends.
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
      {{"--loop", "lateral-displacement", "--kq", "1"}, "--kq"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args{"set-gains"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = tribo(args);
    EXPECT_EQ(r.exit_code, 2) << c.named << ": " << r.err;
    EXPECT_NE(r.err.find(c.named), std::string::npos) << r.err;
  }
  const auto no_value =
      run_command({DaemonProcess::tribo_cli_path(), "set-gains", "--loop", "lateral-displacement", "--kp"});
  EXPECT_EQ(no_value.exit_code, 2);
  EXPECT_NE(no_value.err.find("--kp: 1 required"), std::string::npos) << no_value.err;
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

// docs/friction_compensation.md: `tribo run --friction-model REPORT` turns the
// compensation on and the run records which report it used; a protocol file
// names its report relative to itself; a report the compensation cannot
// represent is refused before anything moves.
TEST(TriboCli, RunWithAFrictionModelRecordsWhichReport) {
  TempDir data, out, files;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const std::string report = std::string(TRIBO_SOURCE_DIR) + "/tests/data/friction_reports/identification.json";
  const auto ran = tribo({"run", kStandardProtocolPath, "--friction-model", report, "--out",
                          (out.path() / "run").string(), "--json"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const auto summary = parse_json<v1::RunSummary>(ran.out);
  EXPECT_EQ(summary.exit_status(), "SUCCESS");
  ASSERT_EQ(summary.friction_compensation_size(), 1);
  EXPECT_EQ(summary.friction_compensation(0).report_sha256(),
            "8e97474e04076d74d1d9601fbd005e21276ec9f28ec6427ff41f64d99bba46bf");
  EXPECT_EQ(summary.friction_compensation(0).segments(), 5u);
  std::string error;
  const auto metadata = wire::read_run_metadata(out.path() / "run", error);
  ASSERT_TRUE(metadata) << error;
  ASSERT_EQ(metadata->start().friction_models_size(), 1);
  const v1::FrictionModelUse& use = metadata->start().friction_models(0);
  EXPECT_EQ(use.report_file(), report);
  EXPECT_EQ(use.report_sha256(), "8e97474e04076d74d1d9601fbd005e21276ec9f28ec6427ff41f64d99bba46bf");
  EXPECT_EQ(use.parameters(3).name(), "sigma0");
  EXPECT_EQ(metadata->start().protocol().friction_compensation().report_json(), slurp(report));
  // The record says which samples the compensation drove: all of them here.
  const std::string csv = slurp(out.path() / "run" / "samples.csv");
  std::istringstream rows(csv);
  std::string row;
  std::getline(rows, row);
  int compensated = 0, total = 0;
  while (std::getline(rows, row)) {
    ++total;
    if (std::stoul(row.substr(row.rfind(',') + 1)) & v1::FRICTION_COMPENSATED) ++compensated;
  }
  EXPECT_EQ(compensated, total);
  EXPECT_EQ(total, 32000);

  // A protocol that names its report, relative to the protocol file.
  std::filesystem::copy_file(report, files.path() / "model.json");
  const std::filesystem::path protocol = files.path() / "scratch.textproto";
  std::ofstream(protocol) << slurp(kStandardProtocolPath) << "\nfriction_compensation { report_file: \"model.json\" }\n";
  const auto checked = tribo({"check", protocol.string()});
  EXPECT_EQ(checked.exit_code, 0) << checked.err;

  // Refused, naming the field and the effect.
  std::string text = slurp(report);
  text.replace(text.find("\"tilt_offset\"", text.find("\"final_model\"")), 13, "\"drift\"");
  std::ofstream(files.path() / "drift.json") << text;
  const auto refused = tribo({"run", kStandardProtocolPath, "--friction-model", (files.path() / "drift.json").string()});
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("friction_compensation.report_json"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("final_model.effects has drift"), std::string::npos) << refused.err;
  const auto missing = tribo({"run", kStandardProtocolPath, "--friction-model", "/no/such/report.json"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("--friction-model: cannot read /no/such/report.json"), std::string::npos) << missing.err;
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

// ------------------------------------------------------------- issue 16

const std::vector<std::string> kCommands{"run",       "check", "status", "abort", "list",  "fetch",   "export",
                                         "gains",     "set-gains", "rearm", "estop", "autotune"};

TEST(TriboCli, AskingForHelpNeverActs) {
  // Nothing listens on port 1: a command that tried to reach the daemon would
  // exit 3. Every command's help must come without a connection...
  for (const std::string& command : kCommands) {
    for (const std::string flag : {"--help", "-h"}) {
      const auto r = run_command({DaemonProcess::tribo_cli_path(), command, flag, "--address", "127.0.0.1:1"});
      EXPECT_EQ(r.exit_code, 0) << command << " " << flag << ": " << r.err;
      EXPECT_NE(r.out.find("tribo " + command), std::string::npos) << command << " " << flag << ": " << r.out;
    }
  }
  // ...and against a live daemon, asking for help changes nothing.
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto gains_before = gains_json(tribo);
  for (const std::string& command : kCommands) {
    EXPECT_EQ(tribo({command, "-h", "--reason", "help"}).exit_code, 0) << command;
    EXPECT_EQ(tribo({command, "--help"}).exit_code, 0) << command;
  }
  const auto status = parse_json<v1::StatusReply>(tribo({"status", "--json"}).out);
  EXPECT_EQ(status.state(), v1::IDLE) << status.DebugString();  // no estop, no load
  EXPECT_FALSE(status.tripped());
  EXPECT_EQ(gains_json(tribo).SerializeAsString(), gains_before.SerializeAsString());  // no autotune
  EXPECT_EQ(parse_json<v1::ListRunsReply>(tribo({"list", "--json"}).out).runs_size(), 0);  // no run
}

TEST(TriboCli, EveryToolSaysItsVersion) {
  for (const std::string& tool : std::vector<std::string>{DaemonProcess::tribo_cli_path(), DaemonProcess::tribod_path(),
                                  std::string(TRIBO_BENCH_PATH)}) {
    const auto r = run_command({tool, "--version"});
    EXPECT_EQ(r.exit_code, 0) << tool << ": " << r.err;
    EXPECT_NE(r.out.find(std::filesystem::path(tool).filename().string() + " "), std::string::npos) << r.out;
    const auto help = run_command({tool, "--help"});
    EXPECT_EQ(help.exit_code, 0) << tool;
    EXPECT_NE(help.out.find("--version"), std::string::npos) << help.out;
  }
}

TEST(TriboCli, UnknownAndUnusedOptionsAreErrors) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto before = gains_json(tribo);
  const auto unused = tribo({"gains", "--kp", "100"});  // gains only reads; --kp belongs to set-gains
  EXPECT_EQ(unused.exit_code, 2) << unused.out;
  EXPECT_NE(unused.err.find("--kp"), std::string::npos) << unused.err;
  EXPECT_EQ(gains_json(tribo).SerializeAsString(), before.SerializeAsString());
  EXPECT_EQ(tribo({"status", "--max", "3"}).exit_code, 2);
  EXPECT_EQ(tribo({"estop", "now"}).exit_code, 2);  // a stray positional is not ignored either
  EXPECT_EQ(parse_json<v1::StatusReply>(tribo({"status", "--json"}).out).state(), v1::IDLE);
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{DaemonProcess::tribod_path(), "--bogus"},
        std::vector<std::string>{DaemonProcess::tribod_path(), "--port", "70000"},
        std::vector<std::string>{DaemonProcess::tribod_path(), "--log-level", "loud"},
        std::vector<std::string>{std::string(TRIBO_BENCH_PATH), "--bogus"}}) {
    EXPECT_EQ(run_command(args).exit_code, 2) << args[1];
  }
}

TEST(TriboCli, UsageErrorsInJsonAreInvalidArgument) {
  const auto r = run_command({DaemonProcess::tribo_cli_path(), "run", "--json", "--address", "127.0.0.1:1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("\"code\": \"INVALID_ARGUMENT\""), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("INTERNAL"), std::string::npos) << r.out;
}

TEST(TriboCli, OutAndFetchRefuseToOverwriteWithoutForce) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto protocol_file = out.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  const auto first = out.path() / "first";
  const auto ran = tribo({"run", protocol_file.string(), "--out", first.string(), "--json"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const std::string run_id = parse_json<v1::RunSummary>(ran.out).run_id();
  const std::string kept = slurp(first / wire::kMetadataFile);

  const auto again = tribo({"run", protocol_file.string(), "--out", first.string()});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("exists already"), std::string::npos) << again.err;
  EXPECT_EQ(parse_json<v1::ListRunsReply>(tribo({"list", "--json"}).out).runs_size(), 1);  // refused before running
  const auto fetched = tribo({"fetch", run_id, "--out", first.string()});
  EXPECT_EQ(fetched.exit_code, 2);
  EXPECT_NE(fetched.err.find("--force"), std::string::npos) << fetched.err;
  std::ofstream(out.path() / "x.csv") << "mine";
  EXPECT_EQ(tribo({"export", run_id, "--out", (out.path() / "x.csv").string()}).exit_code, 2);
  EXPECT_EQ(slurp(out.path() / "x.csv"), "mine");
  EXPECT_TRUE(slurp(first / wire::kMetadataFile) == kept);

  EXPECT_EQ(tribo({"fetch", run_id, "--out", first.string(), "--force"}).exit_code, 0);
  EXPECT_EQ(tribo({"run", protocol_file.string(), "--out", first.string(), "--force"}).exit_code, 0);
  EXPECT_FALSE(slurp(first / wire::kMetadataFile) == kept);
}

// Issue 13: `tribo run` kept every sample in memory (489 MB an hour at
// 1 kHz). It writes them to --out as they arrive and reads the summary back a
// segment at a time: a 4-minute run of 1-4 s segments (242 000 samples) is
// held at most one fetched page (32 768) or one segment and one read page at
// a time, and its samples.csv is the daemon's recording, byte for byte.
TEST(TriboCli, RunStreamsToDiskHoldingOnlyAPageOfSamples) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  v1::Protocol protocol;
  ASSERT_FALSE(wire::load_text_proto_file(std::string(TRIBO_SOURCE_DIR) + "/config/protocols/repeated_scratch.textproto",
                                          protocol));
  protocol.mutable_segments(1)->mutable_repeat()->set_count(30);
  const auto protocol_file = out.path() / "long.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(protocol);
  ::setenv("TRIBO_TEST_SAMPLES_HELD", "1", 1);
  const auto ran = tribo({"run", protocol_file.string(), "--out", (out.path() / "run").string(), "--json"});
  ::unsetenv("TRIBO_TEST_SAMPLES_HELD");
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const auto summary = parse_json<v1::RunSummary>(ran.out);
  EXPECT_GE(summary.sample_count(), 242000u);
  EXPECT_EQ(summary.scratches_size(), 30);
  const std::string marker = "samples held at most ";
  const auto at = ran.err.find(marker);
  ASSERT_NE(at, std::string::npos) << "no report of the samples held: " << ran.err;
  const std::uint64_t held = std::stoull(ran.err.substr(at + marker.size()));
  EXPECT_LE(held, 32768u) << ran.err;
  EXPECT_LT(held * 4, summary.sample_count()) << ran.err;
  EXPECT_TRUE(slurp(out.path() / "run" / wire::kSamplesFile) == slurp(data.path() / summary.run_id() / wire::kSamplesFile));
  EXPECT_FALSE(std::filesystem::exists(out.path() / "run" / "samples.csv.tmp"));
}

TEST(TriboCli, RunAnnotationsAreRecordedAndListed) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto protocol_file = out.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  EXPECT_EQ(tribo({"run", protocol_file.string(), "--meta", "humidity"}).exit_code, 2);  // not KEY=VALUE
  const auto ran = tribo({"run", protocol_file.string(), "--sample", "DLC film 3", "--tip", "Berkovich #7",
                          "--operator", "A. Scientist", "--note", "after cleaning", "--meta", "humidity_pct=41",
                          "--meta", "batch=B2", "--out", (out.path() / "run").string()});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const auto runs = parse_json<v1::ListRunsReply>(tribo({"list", "--json"}).out);
  ASSERT_EQ(runs.runs_size(), 1);
  const auto& a = runs.runs(0).annotations();
  EXPECT_EQ(a.sample(), "DLC film 3");
  EXPECT_EQ(a.tip(), "Berkovich #7");
  EXPECT_EQ(a.operator_name(), "A. Scientist");
  EXPECT_EQ(a.note(), "after cleaning");
  EXPECT_EQ(a.extra().at("humidity_pct"), "41");
  EXPECT_EQ(a.extra().at("batch"), "B2");
  const auto text = tribo({"list"}).out;
  EXPECT_NE(text.find("sample=DLC film 3  tip=Berkovich #7  operator=A. Scientist  batch=B2  humidity_pct=41  "
                      "note: after cleaning"),
            std::string::npos)
      << text;
}

TEST(Tribod, LogsToAFileInUtcAtTheGivenLevel) {
  TempDir data, logs;
  const auto log = logs.path() / "tribod.log";
  {
    DaemonProcess daemon(data.path(), DaemonProcess::default_config_path(),
                         {"--log-file", log.string(), "--log-level", "debug"});
    const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
    EXPECT_EQ(tribo({"status"}).exit_code, 0);
  }
  const std::string text = slurp(log);
  EXPECT_NE(text.find("serving on"), std::string::npos) << text;
  // Every line: [2026-11-23T17:28:32.123Z] ..., the zone stated.
  std::istringstream lines(text);
  std::string line;
  int n = 0;
  while (std::getline(lines, line)) {
    ++n;
    ASSERT_GE(line.size(), 26u) << line;
    EXPECT_EQ(line[0], '[') << line;
    EXPECT_EQ(line[11], 'T') << line;
    EXPECT_EQ(line.substr(24, 2), "Z]") << line;
  }
  EXPECT_GT(n, 0);
}

TEST(TriboCli, StatusShowsTheTripReason) {
  TempDir data;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  ASSERT_EQ(tribo({"estop", "--reason", "smoke from the stage"}).exit_code, 0);
  const auto status = parse_json<v1::StatusReply>(tribo({"status", "--json"}).out);
  ASSERT_FALSE(status.trip_reason().empty()) << status.DebugString();
  const auto text = tribo({"status"});
  EXPECT_NE(text.out.find("trip       " + status.trip_reason()), std::string::npos) << text.out;
}

TEST(TriboCli, CheckIsTheDryRunWithWarningsAndAPlot) {
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  v1::Protocol slow = short_protocol();
  slow.mutable_segments(2)->mutable_lateral()->set_end_um(2.1);  // 0.1 µm/s over 1 s
  slow.mutable_segments(3)->mutable_lateral()->set_end_um(2.1);
  const auto protocol_file = out.path() / "slow.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(slow);
  const auto png = out.path() / "plan.png";
  const auto checked = tribo({"check", protocol_file.string(), "--plot", png.string(), "--config",
                              DaemonProcess::default_config_path()});
  ASSERT_EQ(checked.exit_code, 0) << checked.err;
  EXPECT_NE(checked.out.find("is valid"), std::string::npos) << checked.out;
  EXPECT_NE(checked.out.find("warning: "), std::string::npos) << checked.out;
  EXPECT_NE(checked.out.find("0.2 µm/s"), std::string::npos) << checked.out;
  EXPECT_EQ(slurp(png).substr(0, 8), "\x89PNG\r\n\x1a\n");
  EXPECT_EQ(parse_json<v1::ListRunsReply>(tribo({"list", "--json"}).out).runs_size(), 0);  // nothing ran

  // The identification protocol's gain change is said where the user looks.
  const auto identification =
      tribo({"check", std::string(TRIBO_SOURCE_DIR) + "/config/protocols/identification.textproto"});
  EXPECT_EQ(identification.exit_code, 0) << identification.err;
  EXPECT_NE(identification.out.find("--setpoint-weight-p 1"), std::string::npos) << identification.out;

  // An invalid protocol: the daemon's error, exit 2.
  v1::Protocol bad = short_protocol();
  bad.mutable_segments(1)->mutable_normal()->set_end_un(1e9);
  std::ofstream(out.path() / "bad.textproto") << wire::to_text_proto(bad);
  const auto refused = tribo({"check", (out.path() / "bad.textproto").string()});
  EXPECT_EQ(refused.exit_code, 2) << refused.out;
  EXPECT_NE(refused.err.find("segments[1].normal.end_uN"), std::string::npos) << refused.err;

  // A segment without duration and speed is said as such (not "duration_s = 0").
  v1::Protocol no_speed = short_protocol();
  no_speed.mutable_segments(2)->set_duration_s(0);
  std::ofstream(out.path() / "no_speed.textproto") << wire::to_text_proto(no_speed);
  const auto missing = tribo({"check", (out.path() / "no_speed.textproto").string()});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("no duration_s and no lateral.speed_um_per_s"), std::string::npos) << missing.err;

  // A syntax error comes with a hint.
  std::ofstream(out.path() / "unclosed.textproto") << "name: \"x\"\nsegments {\n  name: \"a\"\n";
  const auto unclosed = tribo({"check", (out.path() / "unclosed.textproto").string()});
  EXPECT_EQ(unclosed.exit_code, 2);
  EXPECT_NE(unclosed.err.find("hint:"), std::string::npos) << unclosed.err;
}

TEST(TriboCli, ExportsAnHdf5FileThatH5pyReads) {
  if (!std::filesystem::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  TempDir data, out;
  DaemonProcess daemon(data.path());
  const Cli tribo{"127.0.0.1:" + std::to_string(daemon.port())};
  const auto protocol_file = out.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  const auto ran = tribo({"run", protocol_file.string(), "--json", "--sample", "steel"});
  ASSERT_EQ(ran.exit_code, 0) << ran.err;
  const auto summary = parse_json<v1::RunSummary>(ran.out);
  const auto h5 = out.path() / "run.h5";
  const auto exported = tribo({"export", summary.run_id(), "--format", "hdf5", "--out", h5.string(), "--json"});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  EXPECT_EQ(parse_json<v1::SavedRun>(exported.out).sample_count(), summary.sample_count());
  const auto script = out.path() / "read.py";
  std::ofstream(script) << R"PY(
import json, sys
import h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
s = f["samples"]
channels = json.loads(f["run/run_descriptor"][()])["channels"]
assert len(channels) == len(s) > 0
for c in channels:
    d = s[c["name"]]
    assert d.attrs["unit"] == c["unit"] and d.attrs["description"] == c["description"], dict(d.attrs)
    assert d.dtype == (np.uint32 if c["block_field"] in ("segment_index", "status_flags") else np.float64)
    if c["block_field"] == "time_s":
        time = d[:]
n = len(time)
assert all(len(s[k]) == n for k in s), {k: len(s[k]) for k in s}
assert np.all(np.diff(time) > 0)
assert f.attrs["run_id"] == sys.argv[2], f.attrs["run_id"]
assert f.attrs["exit_status"] == "SUCCESS"
start = json.loads(f["run/start"][()])
assert start["run_id"] == sys.argv[2]
assert json.loads(f["run/stop"][()])["exit_status"] == "SUCCESS"
print(n)
)PY";
  const auto read = run_command({"/usr/bin/python3", script.string(), h5.string(), summary.run_id()});
  ASSERT_EQ(read.exit_code, 0) << read.err;
  EXPECT_EQ(std::stoul(read.out), summary.sample_count());
}

// Starts `tribo ARGS...` in the background with stdout and stderr to files.
struct BackgroundCli {
  pid_t pid = -1;
  std::filesystem::path out, err;
  BackgroundCli(const std::vector<std::string>& args, const std::filesystem::path& dir)
      : out(dir / "out.txt"), err(dir / "err.txt") {
    pid = fork();
    if (pid == 0) {
      const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(o, STDOUT_FILENO);
      dup2(e, STDERR_FILENO);
      std::vector<char*> argv;
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
  }
  int wait() {
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
};

void wait_for_samples(client::TriboClient& observer) {
  while (!observer.next_event().has_samples()) {
  }
}

TEST(TriboCli, CtrlCAbortsTheRunAndSaysWhatHappened) {
  TempDir data, cfg;
  DaemonProcess daemon(data.path(), write_config(cfg, paced_config()));
  client::TriboClient observer({"127.0.0.1", daemon.port()}, observer_session());
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  observer.request(subscribe);
  const auto protocol_file = cfg.path() / "short.textproto";
  std::ofstream(protocol_file) << wire::to_text_proto(short_protocol());
  BackgroundCli cli({DaemonProcess::tribo_cli_path(), "run", protocol_file.string(), "--address",
                     "127.0.0.1:" + std::to_string(daemon.port())},
                    cfg.path());
  wait_for_samples(observer);
  kill(cli.pid, SIGINT);
  EXPECT_EQ(cli.wait(), 130);
  const std::string out = slurp(cli.out), err = slurp(cli.err);
  EXPECT_NE(out.find(": ABORT (interrupted (Ctrl-C) in tribo run)"), std::string::npos) << out << err;
  EXPECT_NE(err.find("interrupted (Ctrl-C): the run was aborted with a safe unload"), std::string::npos) << err;
}

TEST(TriboCli, AbortFromAnotherTerminalStopsTheCliRun) {
  TempDir data, cfg;
  v1::DaemonConfig config = paced_config();
  config.mutable_server()->set_control_token("tok");
  struct {
    TempDir& cfg;
    DaemonProcess daemon;
  } guarded{cfg, DaemonProcess(data.path(), write_config(cfg, config))};
  const Cli tribo{"127.0.0.1:" + std::to_string(guarded.daemon.port())};
  client::TriboClient observer({"127.0.0.1", guarded.daemon.port()}, observer_session());
  v1::ClientMessage subscribe;
  subscribe.mutable_subscribe();
  observer.request(subscribe);
  const auto protocol_file = guarded.cfg.path() / "long.textproto";
  v1::Protocol long_protocol = short_protocol();
  long_protocol.mutable_segments(2)->set_duration_s(30);  // far longer than the test
  long_protocol.mutable_segments(2)->mutable_lateral()->set_end_um(8);
  long_protocol.mutable_segments(3)->mutable_lateral()->set_end_um(8);
  std::ofstream(protocol_file) << wire::to_text_proto(long_protocol);
  BackgroundCli run({DaemonProcess::tribo_cli_path(), "run", protocol_file.string(), "--token", "tok", "--address",
                     "127.0.0.1:" + std::to_string(guarded.daemon.port())},
                    guarded.cfg.path());
  wait_for_samples(observer);
  EXPECT_EQ(tribo({"abort"}).exit_code, 4);  // without the token: refused
  const auto aborted = tribo({"abort", "--token", "tok", "--reason", "from the other terminal"});
  if (aborted.exit_code != 0) kill(run.pid, SIGINT);  // the run's own Ctrl-C ends it
  EXPECT_EQ(aborted.exit_code, 0) << aborted.err;
  EXPECT_EQ(run.wait(), 1);  // the run ended in ABORT
  EXPECT_NE(slurp(run.out).find("ABORT (from the other terminal)"), std::string::npos) << slurp(run.out);
}

}  // namespace
}  // namespace tribo::testing
