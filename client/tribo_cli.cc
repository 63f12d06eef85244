// tribo: the command-line client of tribod. See kUsageText for commands,
// options and exit codes.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include <google/protobuf/util/json_util.h>

#include "client/control_loops.h"
#include "client/run_progress.h"
#include "client/run_summary.h"
#include "client/tribo_client.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "tribo/v1/protocol.pb.h"

namespace {

constexpr const char* kUsageText =
    "usage: tribo COMMAND [ARGS] [--json] [--address HOST:PORT] [--token TOKEN]\n"
    "commands:\n"
    "  run PROTOCOL.textproto [--out DIR] [--seed N] [--progress|--no-progress]\n"
    "              load the protocol, run it, stream the samples with a live progress\n"
    "              line (on a terminal), print the summary (friction in µN, mu,\n"
    "              stiction peak, lag in µm); --out also saves the run there\n"
    "  status      the daemon's state, the current run, recording and backend health\n"
    "  abort [--reason TEXT]\n"
    "              stop the running protocol (safe unload)\n"
    "  list [--max N]\n"
    "              the recorded runs, newest first\n"
    "  fetch RUN_ID [--out DIR]\n"
    "              copy a recorded run (metadata.json, samples.csv) to DIR (default ./RUN_ID)\n"
    "  export RUN_ID [--out FILE]\n"
    "              the run's samples.csv as recorded, to FILE or stdout\n"
    "  gains [--loop LOOP]\n"
    "              every loop's PID gains (or LOOP's), SI units: the output is a drive\n"
    "              force in N; kp N/m, ki N/(m s), kd N s/m for the displacement loops,\n"
    "              kp N/N, ki 1/s, kd s for the force loops\n"
    "  set-gains --loop LOOP [--kp X] [--ki X] [--kd X] [--setpoint-weight-p X]\n"
    "            [--setpoint-weight-d X] [--derivative-filter-hz X] [--output-min N]\n"
    "            [--output-max N] [--tracking-time-s X] [--feedforward-gain X]\n"
    "            [--anti-windup anti-windup-none|back-calculation|conditional-integration]\n"
    "              change only the given gains of LOOP (SI units, as for gains), also\n"
    "              for a running run (bumplessly); prints what the daemon applied\n"
    "  rearm       leave FAULTED after a safety trip or an emergency stop\n"
    "  estop [--reason TEXT]\n"
    "              emergency stop: safe stop sequence, then FAULTED until rearm (any\n"
    "              client may; no control needed)\n"
    "  autotune [--relay-amplitude-n N] [--hysteresis-m M] [--apply]\n"
    "              relay autotune of the lateral displacement loop (not during a run):\n"
    "              ultimate gain and period, proposed gains; --apply applies them\n"
    "LOOP: lateral-displacement, lateral-force, normal-force, normal-displacement\n"
    "options:\n"
    "  --json      print JSON for scripts (protobuf field names; see README)\n"
    "  --address   tribod's address (default $TRIBO_ADDRESS or 127.0.0.1:7460)\n"
    "  --token     the daemon's control token for run, abort, set-gains, rearm and\n"
    "              autotune (default $TRIBO_TOKEN)\n"
    "exit codes: 0 success; 1 the run ended in ABORT or FAULT; 2 bad usage, an invalid\n"
    "  protocol or argument; 3 daemon unreachable or connection lost; 4 not allowed\n"
    "  (wrong token, or another client holds control); 5 wrong state (e.g. abort\n"
    "  without a run); 6 no such run; 7 the daemon or the file system failed\n";

enum ExitCode {
  kOk = 0,
  kRunFailed = 1,
  kUsage = 2,
  kConnection = 3,
  kNotAllowed = 4,
  kWrongState = 5,
  kNotFound = 6,
  kFailed = 7,
};

struct Options {
  std::string command;
  std::vector<std::string> args;  // positional
  std::map<std::string, std::string> values;
  bool json = false;
  bool apply = false;  // autotune: apply the proposed gains
  std::optional<bool> progress;
  tribo::client::Address address = tribo::client::default_address();
  std::string token = tribo::client::default_token();

  std::optional<std::string> value(const std::string& key) const {
    const auto it = values.find(key);
    return it == values.end() ? std::nullopt : std::optional(it->second);
  }
};

bool takes_value(const std::string& name) {
  static const std::set<std::string> names = [] {
    std::set<std::string> n{"out", "seed", "reason", "max", "loop", "anti-windup", "relay-amplitude-n",
                            "hysteresis-m"};
    for (std::string field : tribo::client::gain_fields()) {
      std::replace(field.begin(), field.end(), '_', '-');
      n.insert(field);
    }
    return n;
  }();
  return names.contains(name);
}

// The options, or a message naming what is wrong with them.
std::variant<Options, std::string> parse_options(int argc, char** argv) {
  if (argc < 2) return std::string("no command given");
  Options o;
  o.command = argv[1];
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    // An option's value never starts with "--" (negative numbers have one dash).
    const bool has_value = i + 1 < argc && !std::string(argv[i + 1]).starts_with("--");
    if (arg == "--json") {
      o.json = true;
    } else if (arg == "--apply") {
      o.apply = true;
    } else if (arg == "--progress" || arg == "--no-progress") {
      o.progress = arg == "--progress";
    } else if (!arg.starts_with("--")) {
      o.args.push_back(arg);
    } else if (arg != "--address" && arg != "--token" && !takes_value(arg.substr(2))) {
      return "unknown option " + arg;
    } else if (!has_value) {
      return "option " + arg + " needs a value";
    } else if (arg == "--address") {
      const auto address = tribo::client::parse_address(argv[++i]);
      if (!address) return "--address " + std::string(argv[i]) + " is not HOST:PORT";
      o.address = *address;
    } else if (arg == "--token") {
      o.token = argv[++i];
    } else {
      o.values[arg.substr(2)] = argv[++i];
    }
  }
  return o;
}

std::optional<std::uint64_t> parse_uint(const std::string& text) {
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || text[0] == '-') return std::nullopt;
  return v;
}

std::string to_json(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

int exit_code_of(const tribo::client::ClientError& e) {
  if (e.connection_lost()) return kConnection;
  switch (e.error().code()) {
    case tribo::v1::INVALID_ARGUMENT:
    case tribo::v1::MALFORMED_REQUEST:
    case tribo::v1::UNSUPPORTED_VERSION:
      return kUsage;
    case tribo::v1::PERMISSION_DENIED:
    case tribo::v1::UNAUTHENTICATED:
      return kNotAllowed;
    case tribo::v1::WRONG_STATE:
      return kWrongState;
    case tribo::v1::NOT_FOUND:
      return kNotFound;
    default:
      return kFailed;
  }
}

// Reports a failure on stderr, and as {"error": ...} on stdout with --json.
int fail(const Options& o, const tribo::v1::Error& error, int code) {
  std::cerr << "tribo: " << (error.field().empty() ? "" : error.field() + ": ") << error.message() << "\n";
  if (o.json) std::cout << "{\"error\": " << to_json(error) << ", \"exit_code\": " << code << "}\n";
  return code;
}

int fail(const Options& o, const std::string& message, int code) {
  tribo::v1::Error error;
  error.set_code(tribo::v1::INTERNAL);
  error.set_message(message);
  return fail(o, error, code);
}

tribo::client::SessionOptions session(const Options& o, tribo::v1::Role role) {
  tribo::client::SessionOptions s;
  s.client_name = "tribo " + o.command;
  s.role = role;
  s.token = o.token;
  return s;
}

int run_command(const Options& o) {
  if (o.args.size() != 1) return fail(o, "run needs one PROTOCOL file", kUsage);
  std::optional<std::uint64_t> seed;
  if (const auto text = o.value("seed")) {
    seed = parse_uint(*text);
    if (!seed) return fail(o, "--seed " + *text + " is not a number", kUsage);
  }
  tribo::v1::Protocol protocol;
  if (auto error = tribo::wire::load_text_proto_file(o.args[0], protocol)) return fail(o, *error, kUsage);

  const bool progress = o.progress.value_or(isatty(STDERR_FILENO) == 1);
  tribo::client::RunProgress line(stderr);
  tribo::client::RunResult run;
  {
    tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
    run = tribo::client::run_protocol(client, protocol, seed, [&](const tribo::v1::ServerMessage& d) {
      if (progress) line.on_document(d);
    });
  }
  line.finish();
  for (const auto& warning : run.loaded.warnings()) std::cerr << "tribo: warning: " << warning << "\n";
  if (run.fetched_samples > 0) {
    std::cerr << "tribo: " << run.fetched_samples
              << " samples missed while streaming were fetched from the daemon's recording\n";
  }
  if (run.missing_samples > 0) {
    std::cerr << "tribo: " << run.missing_samples << " samples are missing from the recording\n";
  }
  tribo::v1::RunSummary summary = tribo::client::summarize_run(run);
  if (const auto out = o.value("out")) {
    tribo::v1::RunMetadata metadata;
    *metadata.mutable_start() = run.start;
    *metadata.mutable_stop() = run.stop;
    *metadata.mutable_run_descriptor() = run.descriptor;
    for (const auto& e : run.segment_events) *metadata.add_segment_events() = e;
    for (const auto& f : run.faults) *metadata.add_faults() = f;
    std::string error;
    if (!tribo::wire::write_run_directory(*out, metadata, run.samples, error)) return fail(o, error, kFailed);
    summary.set_saved_to(*out);
  }
  std::cout << (o.json ? tribo::client::summary_json(summary) + "\n" : tribo::client::summary_text(summary));
  return run.stop.exit_status() == tribo::v1::SUCCESS ? kOk : kRunFailed;
}

std::string status_text(const tribo::v1::StatusReply& s) {
  char buf[512];
  std::string text = "state      " + tribo::v1::DaemonState_Name(s.state()) + "\n";
  if (!s.loaded_protocol().empty()) text += "protocol   " + s.loaded_protocol() + "\n";
  if (!s.run_id().empty()) {
    std::snprintf(buf, sizeof buf, "run        %s: %.1f of %.1f s, %llu samples recorded, %llu dropped\n",
                  s.run_id().c_str(), s.run_time_s(), s.run_duration_s(),
                  static_cast<unsigned long long>(s.samples_recorded()),
                  static_cast<unsigned long long>(s.samples_dropped()));
    text += buf;
  }
  text += "backend    " + s.backend_health().backend() + ": " +
          (s.backend_health().healthy() ? "healthy" : "UNHEALTHY") + " (" + s.backend_health().detail() + ")\n";
  std::snprintf(buf, sizeof buf, "clients    %s, %u observer(s); %llu gap notice(s) sent\n",
                s.controller_connected() ? "a controller" : "no controller", s.observers(),
                static_cast<unsigned long long>(s.gap_notices()));
  return text + buf;
}

int status_command(const Options& o) {
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  tribo::v1::ClientMessage request;
  request.mutable_get_status();
  const tribo::v1::StatusReply status = client.request(request).status();
  std::cout << (o.json ? to_json(status) + "\n" : status_text(status));
  return kOk;
}

int abort_command(const Options& o) {
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
  tribo::v1::ClientMessage request;
  request.mutable_abort_run()->set_reason(o.value("reason").value_or("aborted from the tribo CLI"));
  const tribo::v1::AbortRunReply reply = client.request(request).abort_run();
  std::cout << (o.json ? to_json(reply) + "\n" : "aborting run " + reply.run_id() + " (safe unload)\n");
  return kOk;
}

int list_command(const Options& o) {
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  tribo::v1::ClientMessage request;
  if (const auto max = o.value("max")) {
    const auto n = parse_uint(*max);
    if (!n) return fail(o, "--max " + *max + " is not a number", kUsage);
    request.mutable_list_runs()->set_max_runs(static_cast<std::uint32_t>(*n));
  } else {
    request.mutable_list_runs();
  }
  const tribo::v1::ListRunsReply reply = client.request(request).list_runs();
  if (o.json) {
    std::cout << to_json(reply) << "\n";
    return kOk;
  }
  for (const auto& r : reply.runs()) {
    char line[512];
    std::snprintf(line, sizeof line, "%-22s %-10s %9llu samples  %-20s %s\n", r.run_id().c_str(),
                  r.finalized() ? tribo::v1::ExitStatus_Name(r.exit_status()).c_str() : "INCOMPLETE",
                  static_cast<unsigned long long>(r.sample_count()), r.start_time_utc().c_str(),
                  r.protocol_name().c_str());
    std::cout << line;
  }
  return kOk;
}

tribo::v1::SavedRun saved_run(const tribo::v1::RunMetadata& metadata, const std::string& to, std::uint64_t n) {
  tribo::v1::SavedRun s;
  s.set_run_id(metadata.start().run_id());
  s.set_saved_to(to);
  s.set_sample_count(n);
  s.set_exit_status(metadata.has_stop() ? tribo::v1::ExitStatus_Name(metadata.stop().exit_status()) : "INCOMPLETE");
  return s;
}

int fetch_command(const Options& o) {
  if (o.args.size() != 1) return fail(o, "fetch needs one RUN_ID", kUsage);
  const std::string out = o.value("out").value_or(o.args[0]);
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  const tribo::wire::RecordedRun run = tribo::client::fetch_run(client, o.args[0]);
  std::string error;
  if (!tribo::wire::write_run_directory(out, run.metadata, run.samples, error)) return fail(o, error, kFailed);
  const auto saved = saved_run(run.metadata, out, static_cast<std::uint64_t>(tribo::sample_count(run.samples)));
  std::cout << (o.json ? to_json(saved) + "\n"
                       : "run " + saved.run_id() + " (" + saved.exit_status() + "): " +
                             std::to_string(saved.sample_count()) + " samples saved to " + out + "\n");
  return kOk;
}

int export_command(const Options& o) {
  if (o.args.size() != 1) return fail(o, "export needs one RUN_ID", kUsage);
  const auto out = o.value("out");
  if (o.json && !out) return fail(o, "export --json needs --out FILE (stdout carries the CSV otherwise)", kUsage);
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  tribo::v1::ClientMessage request;
  request.mutable_get_run()->set_run_id(o.args[0]);
  const tribo::v1::RunMetadata metadata = client.request(request).get_run().metadata();
  std::ofstream file;
  if (out) {
    file.open(*out, std::ios::binary | std::ios::trunc);
    if (!file) return fail(o, "cannot write " + *out, kFailed);
  }
  std::ostream& stream = out ? static_cast<std::ostream&>(file) : std::cout;
  const std::uint64_t rows = tribo::client::export_csv(client, o.args[0], stream);
  stream.flush();
  if (!stream) return fail(o, "writing the CSV failed", kFailed);
  if (out) {
    const auto saved = saved_run(metadata, *out, rows);
    std::cout << (o.json ? to_json(saved) + "\n" : std::to_string(rows) + " samples written to " + *out + "\n");
  }
  return kOk;
}

// A finite number, or a message naming the option.
std::variant<double, std::string> parse_number(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') return "--" + option + " " + text + " is not a number";
  if (!std::isfinite(v)) return "--" + option + " " + text + " is not a finite number";
  return v;
}

// --loop as a ControlLoop, or a message saying which names exist.
std::variant<tribo::v1::ControlLoop, std::string> loop_option(const Options& o) {
  const auto text = o.value("loop");
  if (!text) return "--loop is required (one of " + tribo::client::loop_names() + ")";
  if (const auto loop = tribo::client::parse_loop(*text)) return *loop;
  return "--loop " + *text + " is not a control loop (one of " + tribo::client::loop_names() + ")";
}

std::string loop_gains_text(tribo::v1::ControlLoop loop, const tribo::v1::PidGains& gains) {
  return tribo::client::loop_name(loop) + " (output: drive force in N)\n" +
         tribo::client::gains_text(loop, gains, "  ");
}

int gains_command(const Options& o) {
  std::optional<tribo::v1::ControlLoop> only;
  if (o.value("loop")) {
    const auto loop = loop_option(o);
    if (const auto* error = std::get_if<std::string>(&loop)) return fail(o, *error, kUsage);
    only = std::get<tribo::v1::ControlLoop>(loop);
  }
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  const tribo::v1::GetGainsReply all = tribo::client::get_gains(client);
  tribo::v1::GetGainsReply reply;
  for (const auto& l : all.loops()) {
    if (!only || l.loop() == *only) *reply.add_loops() = l;
  }
  if (o.json) {
    std::cout << to_json(reply) << "\n";
    return kOk;
  }
  for (const auto& l : reply.loops()) std::cout << loop_gains_text(l.loop(), l.gains());
  return kOk;
}

// The gains with every gain option of the command line applied.
std::variant<tribo::v1::PidGains, std::string> changed_gains(const Options& o, tribo::v1::PidGains gains) {
  for (const auto& field : tribo::client::gain_fields()) {
    std::string option = field;
    std::replace(option.begin(), option.end(), '_', '-');
    const auto text = o.value(option);
    if (!text) continue;
    const auto value = parse_number(option, *text);
    if (const auto* error = std::get_if<std::string>(&value)) return *error;
    tribo::client::set_gain_field(gains, field, std::get<double>(value));
  }
  if (const auto text = o.value("anti-windup")) {
    tribo::v1::AntiWindup mode;
    std::string name = *text;
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::toupper(c); });
    std::replace(name.begin(), name.end(), '-', '_');
    if (!tribo::v1::AntiWindup_Parse(name, &mode) || mode == tribo::v1::ANTI_WINDUP_UNSPECIFIED) {
      return "--anti-windup " + *text + " is not one of anti-windup-none, back-calculation, conditional-integration";
    }
    gains.set_anti_windup(mode);
  }
  return gains;
}

int set_gains_command(const Options& o) {
  const auto loop = loop_option(o);
  if (const auto* error = std::get_if<std::string>(&loop)) return fail(o, *error, kUsage);
  const tribo::v1::ControlLoop which = std::get<tribo::v1::ControlLoop>(loop);
  // Check the numbers before touching the daemon; the daemon checks the limits.
  if (const auto checked = changed_gains(o, {}); std::holds_alternative<std::string>(checked)) {
    return fail(o, std::get<std::string>(checked), kUsage);
  }
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
  const auto current = tribo::client::loop_gains(tribo::client::get_gains(client), which);
  if (!current) return fail(o, "the daemon reports no gains for " + tribo::client::loop_name(which), kFailed);
  const auto gains = changed_gains(o, *current);
  const tribo::v1::SetGainsReply reply =
      tribo::client::set_gains(client, which, std::get<tribo::v1::PidGains>(gains));
  if (o.json) {
    std::cout << to_json(reply) << "\n";
    return kOk;
  }
  std::cout << "applied " << loop_gains_text(reply.loop(), reply.gains())
            << (reply.applied_to_running_run() ? "(also to the running run, bumplessly)\n" : "");
  return kOk;
}

int rearm_command(const Options& o) {
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
  tribo::v1::ClientMessage request;
  request.mutable_rearm();
  const tribo::v1::RearmReply r = client.request(request).rearm();
  if (o.json) {
    std::cout << to_json(r) << "\n";
    return kOk;
  }
  char text[256];
  std::snprintf(text, sizeof text,
                "re-armed; setpoints re-synced to the instrument: lateral position %.4f µm, "
                "normal force %.2f µN, normal displacement %.4f µm (lateral force %.2f µN)\n",
                r.lateral_position_m() * 1e6, r.normal_force_n() * 1e6, r.normal_displacement_m() * 1e6,
                r.lateral_force_n() * 1e6);
  std::cout << text;
  return kOk;
}

int estop_command(const Options& o) {
  // Any client may stop the instrument: no control needed.
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  tribo::v1::ClientMessage request;
  request.mutable_emergency_stop()->set_reason(o.value("reason").value_or("emergency stop from the tribo CLI"));
  const tribo::v1::EmergencyStopReply r = client.request(request).emergency_stop();
  std::cout << (o.json ? to_json(r) + "\n"
                       : std::string(r.run_was_active() ? "the run is stopping (safe stop sequence); "
                                                        : "no run was active; ") +
                             "the instrument is FAULTED until `tribo rearm`\n");
  return kOk;
}

std::string autotune_text(const tribo::v1::AutotuneReply& r) {
  char text[512];
  std::snprintf(text, sizeof text,
                "relay autotune of lateral-displacement: %u cycles, amplitude %.4f µm\n"
                "  ultimate gain Ku     %g N/m\n"
                "  ultimate period Pu   %g s\n"
                "  proposed (%s), %s:\n",
                r.cycles(), r.oscillation_amplitude_m() * 1e6, r.ultimate_gain_n_per_m(), r.ultimate_period_s(),
                r.rule().c_str(), r.applied() ? "applied" : "not applied (--apply applies them)");
  return text + tribo::client::gains_text(tribo::v1::LOOP_LATERAL_DISPLACEMENT, r.proposed(), "    ");
}

int autotune_command(const Options& o) {
  tribo::v1::ClientMessage request;
  tribo::v1::Autotune& tune = *request.mutable_autotune();
  for (const char* option : {"relay-amplitude-n", "hysteresis-m"}) {
    const auto text = o.value(option);
    if (!text) continue;
    const auto value = parse_number(option, *text);
    if (const auto* error = std::get_if<std::string>(&value)) return fail(o, *error, kUsage);
    if (std::string(option) == "relay-amplitude-n") tune.set_relay_amplitude_n(std::get<double>(value));
    else tune.set_hysteresis_m(std::get<double>(value));
  }
  tune.set_apply(o.apply);
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
  const tribo::v1::AutotuneReply r = client.request(request).autotune();
  std::cout << (o.json ? to_json(r) + "\n" : autotune_text(r));
  return kOk;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << kUsageText;
    return kOk;
  }
  auto parsed = parse_options(argc, argv);
  if (const auto* error = std::get_if<std::string>(&parsed)) {
    std::cerr << "tribo: " << *error << "\n" << kUsageText;
    return kUsage;
  }
  const Options& options = std::get<Options>(parsed);
  const std::map<std::string, int (*)(const Options&)> commands{
      {"run", run_command},     {"status", status_command},     {"abort", abort_command},
      {"list", list_command},   {"fetch", fetch_command},       {"export", export_command},
      {"gains", gains_command}, {"set-gains", set_gains_command}, {"rearm", rearm_command},
      {"estop", estop_command}, {"autotune", autotune_command}};
  const auto command = commands.find(options.command);
  if (command == commands.end()) {
    std::cerr << "tribo: unknown command " << options.command << "\n" << kUsageText;
    return kUsage;
  }
  try {
    return command->second(options);
  } catch (const tribo::client::ClientError& e) {
    return fail(options, e.error(), exit_code_of(e));
  }
}
