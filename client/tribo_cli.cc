// tribo: the command-line client of tribod. `tribo --help` lists the
// commands, `tribo COMMAND --help` each command's options (asking for help
// never talks to the daemon); docs/cli.md has the exit codes and examples.
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include "client/run_annotations.h"
#include "client/control_loops.h"
#include "client/hdf5_export.h"
#include "client/friction_model_files.h"
#include "client/protocol_check.h"
#include "client/run_progress.h"
#include "client/run_stream_writer.h"
#include "client/segment_reader.h"
#include "client/run_summary.h"
#include "client/tribo_client.h"
#include "client/user_messages.h"
#include "daemon/daemon_config.h"
#include "proto/run_files.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"
#include "tribo/v1/protocol.pb.h"
#include "tribo/version.h"

namespace {

constexpr const char* kDescription =
    "tribo: the command-line client of tribod, the friction instrument's daemon.\n"
    "Friction in µN, positions in µm, SI in --json gains. `tribo COMMAND --help` shows\n"
    "a command's options; asking for help never talks to the daemon.";

constexpr const char* kExitCodes =
    "every command also takes --json, --address HOST:PORT and --token TOKEN (tribo --help)\n"
    "exit codes: 0 success; 1 the run ended in ABORT or FAULT; 2 bad usage, an invalid\n"
    "  protocol or argument; 3 daemon unreachable or connection lost; 4 not allowed\n"
    "  (wrong token, or another client holds control); 5 wrong state (e.g. abort\n"
    "  without a run); 6 no such run; 7 the daemon or the file system failed;\n"
    "  130 interrupted (Ctrl-C) during a run\n";

enum ExitCode {
  kOk = 0,
  kRunFailed = 1,
  kUsage = 2,
  kConnection = 3,
  kNotAllowed = 4,
  kWrongState = 5,
  kNotFound = 6,
  kFailed = 7,
  kInterrupted = 130,
};

struct Options {
  std::string command;
  std::string positional;  // PROTOCOL or RUN_ID
  std::map<std::string, std::string> values;
  std::vector<std::string> meta;  // --meta KEY=VALUE, in order
  bool json = false;
  bool apply = false;  // autotune: apply the proposed gains
  bool force = false;  // run --out, fetch, export --out: replace what is there
  std::optional<bool> progress;
  std::string address_text;
  tribo::client::Address address = tribo::client::default_address();
  std::string token = tribo::client::default_token();

  std::optional<std::string> value(const std::string& key) const {
    const auto it = values.find(key);
    return it == values.end() ? std::nullopt : std::optional(it->second);
  }
};

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

// The error code a failure of the CLI itself carries in --json: usage errors
// are INVALID_ARGUMENT, not INTERNAL.
tribo::v1::ErrorCode error_code_of(int exit_code) {
  switch (exit_code) {
    case kUsage:
      return tribo::v1::INVALID_ARGUMENT;
    case kWrongState:
      return tribo::v1::WRONG_STATE;
    case kNotFound:
      return tribo::v1::NOT_FOUND;
    case kNotAllowed:
      return tribo::v1::PERMISSION_DENIED;
    default:
      return tribo::v1::INTERNAL;
  }
}

// Reports a failure on stderr, and as {"error": ...} on stdout with --json.
int fail(bool json, tribo::v1::Error error, int code) {
  error.set_message(tribo::client::explain_missing_duration(tribo::client::collapse_repeated_lines(error.message())));
  std::cerr << "tribo: " << (error.field().empty() ? "" : error.field() + ": ") << error.message() << "\n";
  if (json) std::cout << "{\"error\": " << to_json(error) << ", \"exit_code\": " << code << "}\n";
  return code;
}

int fail(const Options& o, const tribo::v1::Error& error, int code) { return fail(o.json, error, code); }

int fail(const Options& o, const std::string& message, int code) {
  tribo::v1::Error error;
  error.set_code(error_code_of(code));
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

// A directory or file that is there already, unless --force: runs are not
// overwritten by accident.
std::optional<std::string> refuse_overwrite(const Options& o, const std::string& path) {
  std::error_code ec;
  if (o.force || !std::filesystem::exists(path, ec)) return std::nullopt;
  return path + " exists already; choose another --out or add --force to replace it";
}

// The protocol file with the friction model reports it names read in (and
// --friction-model's in place of its own), or the loader's message with a
// hint for the syntax errors protobuf reports tersely.
std::variant<tribo::v1::Protocol, std::string> load_protocol(const Options& o) {
  const std::string& path = o.positional;
  tribo::v1::Protocol protocol;
  if (auto error = tribo::wire::load_text_proto_file(path, protocol)) {
    return tribo::client::with_syntax_hint(*error);
  }
  if (auto error = tribo::client::read_friction_reports(protocol, std::filesystem::path(path).parent_path())) {
    return path + ": " + *error;
  }
  if (const auto report = o.value("friction-model")) {
    if (auto error = tribo::client::set_friction_model(protocol, *report)) return *error;
  }
  return protocol;
}

// Ctrl-C during `tribo run`: the first asks the daemon to abort the run (safe
// unload) and lets the summary say what happened; a second one leaves at once.
std::atomic<int> g_interrupts{0};

extern "C" void on_interrupt(int) {
  if (g_interrupts.fetch_add(1) >= 1) {
    constexpr char kMessage[] = "\ntribo: interrupted again; leaving without waiting for the run to stop\n";
    (void)!write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
    _exit(kInterrupted);
  }
}

// Where `tribo run` writes the run as it streams: --out, or a scratch
// directory under $TMPDIR that goes once the summary is printed (the summary
// is read back from it a segment at a time: client/segment_reader.h).
class RunDirectory {
 public:
  bool create(const std::optional<std::string>& out, std::string& error) {
    if (out) {
      path_ = *out;
      std::error_code ec;
      created_ = !std::filesystem::exists(path_, ec);
      return true;
    }
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/tribo-run.XXXXXX";
    if (!mkdtemp(pattern.data())) {
      error = "cannot create a scratch directory " + pattern + " for the run's samples: " + std::strerror(errno) +
              " (set TMPDIR, or give --out)";
      return false;
    }
    path_ = pattern;
    scratch_ = true;
    return true;
  }
  // A run that failed before its files were whole leaves no --out directory
  // it made (the daemon's recording has the run).
  ~RunDirectory() {
    std::error_code ec;
    if (scratch_ || (created_ && !keep_)) std::filesystem::remove_all(path_, ec);
  }
  void keep() { keep_ = true; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  bool scratch_ = false, created_ = false, keep_ = false;
};

// TRIBO_TEST_SAMPLES_HELD set: `tribo run` says on stderr the most samples
// it held in memory at once (tests of its bounded memory).
void report_samples_held(std::uint64_t held) {
  if (std::getenv("TRIBO_TEST_SAMPLES_HELD")) std::cerr << "tribo: test: samples held at most " << held << "\n";
}

int run_command(const Options& o) {
  std::optional<std::uint64_t> seed;
  if (const auto text = o.value("seed")) {
    seed = parse_uint(*text);
    if (!seed) return fail(o, "--seed " + *text + " is not a number", kUsage);
  }
  const auto loaded = load_protocol(o);
  if (const auto* error = std::get_if<std::string>(&loaded)) return fail(o, *error, kUsage);
  const auto& protocol = std::get<tribo::v1::Protocol>(loaded);
  const auto out = o.value("out");
  if (out) {
    if (auto refusal = refuse_overwrite(o, *out)) return fail(o, *refusal, kUsage);
  }
  tribo::v1::StartRun start;
  if (seed) start.set_seed(*seed);
  tribo::v1::RunAnnotations& notes = *start.mutable_annotations();
  notes.set_sample(o.value("sample").value_or(""));
  notes.set_tip(o.value("tip").value_or(""));
  notes.set_operator_name(o.value("operator").value_or(""));
  notes.set_note(o.value("note").value_or(""));
  for (const auto& kv : o.meta) {
    if (auto error = tribo::client::add_annotation(notes, kv); !error.empty()) return fail(o, error, kUsage);
  }

  RunDirectory directory;
  tribo::client::RunStreamWriter writer;
  std::string error;
  if (!directory.create(out, error) || !writer.open(directory.path(), error)) return fail(o, error, kFailed);

  const bool progress = o.progress.value_or(isatty(STDERR_FILENO) == 1);
  tribo::client::RunProgress line(stderr);
  tribo::client::RunDocuments run;
  std::string interrupt_note;
  struct sigaction action {}, previous {};
  action.sa_handler = on_interrupt;
  action.sa_flags = SA_RESTART;  // a blocking read goes on; the next document sends the abort
  sigaction(SIGINT, &action, &previous);
  bool written = false;
  {
    tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
    bool abort_sent = false;
    const auto on_samples = [&](const tribo::v1::SampleBlock& block) { writer.append(block); };
    run = tribo::client::stream_run(client, protocol, start, on_samples, [&](const tribo::v1::ServerMessage& d) {
      if (progress) line.on_document(d);
      if (g_interrupts.load() == 0 || abort_sent || d.has_run_stop()) return;
      abort_sent = true;
      tribo::v1::ClientMessage abort;
      abort.mutable_abort_run()->set_reason("interrupted (Ctrl-C) in tribo run");
      try {
        client.request(abort);
        interrupt_note = "interrupted (Ctrl-C): the run was aborted with a safe unload";
      } catch (const tribo::client::ClientError& e) {
        interrupt_note = "interrupted (Ctrl-C), but the abort failed: " + e.error().message();
      }
      if (progress) line.finish();
      std::cerr << "tribo: " << interrupt_note << "; waiting for the run to stop (Ctrl-C again to leave)\n";
    });
    // What the stream missed is in the daemon's recording.
    const auto fetch = [&](std::uint64_t from, std::uint64_t end,
                           const std::function<void(const tribo::v1::SampleBlock&)>& page) {
      tribo::client::fetch_sample_pages(client, run.run_id, from, end, page);
    };
    written = writer.finish(run.stop.sample_count(), fetch, run.metadata(), error);
  }
  sigaction(SIGINT, &previous, nullptr);
  line.finish();
  for (const auto& warning : run.loaded.warnings()) std::cerr << "tribo: warning: " << warning << "\n";
  if (writer.fetched_samples() > 0) {
    std::cerr << "tribo: " << writer.fetched_samples()
              << " samples missed while streaming were fetched from the daemon's recording\n";
  }
  if (writer.missing_samples() > 0) {
    std::cerr << "tribo: " << writer.missing_samples() << " samples are missing from the recording\n";
  }
  if (!written) return fail(o, error, kFailed);
  directory.keep();
  std::uint64_t summary_held = 0;
  auto summary = tribo::client::summarize_recording(run, directory.path(), tribo::client::kSegmentCapSamples, error,
                                                    &summary_held);
  if (!summary) return fail(o, error, kFailed);
  report_samples_held(std::max(writer.peak_samples_held(), summary_held));
  if (out) summary->set_saved_to(*out);
  std::cout << (o.json ? tribo::client::summary_json(*summary) + "\n" : tribo::client::summary_text(*summary));
  if (g_interrupts.load() > 0) {
    std::cerr << "tribo: " << (interrupt_note.empty() ? "interrupted (Ctrl-C)" : interrupt_note) << "\n";
    return kInterrupted;
  }
  return run.stop.exit_status() == tribo::v1::SUCCESS ? kOk : kRunFailed;
}

std::string status_text(const tribo::v1::StatusReply& s) {
  std::string text = "state      " + tribo::v1::DaemonState_Name(s.state()) + "\n";
  if (!s.loaded_protocol().empty()) text += "protocol   " + s.loaded_protocol() + "\n";
  if (!s.run_id().empty()) {
    text += fmt::format("run        {}: {:.1f} of {:.1f} s, {} samples recorded, {} dropped\n", s.run_id(),
                        s.run_time_s(), s.run_duration_s(), s.samples_recorded(), s.samples_dropped());
  }
  if (s.tripped() || !s.trip_reason().empty()) {
    text += fmt::format("trip       {}{} (at {:.3f} s of the run){}\n", s.tripped() ? "" : "last: ", s.trip_reason(),
                        s.trip_time_s(), s.tripped() ? "; `tribo rearm` after checking the instrument" : "");
  }
  text += "backend    " + s.backend_health().backend() + ": " +
          (s.backend_health().healthy() ? "healthy" : "UNHEALTHY") + " (" + s.backend_health().detail() + ")\n";
  text += fmt::format("clients    {}, {} observer(s); {} gap notice(s) sent\n",
                      s.controller_connected() ? "a controller" : "no controller", s.observers(), s.gap_notices());
  if (!s.loop_scheduling().empty()) text += "loop       " + s.loop_scheduling() + "\n";
  return text;
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
  tribo::v1::ClientMessage request;
  request.mutable_abort_run()->set_reason(o.value("reason").value_or("aborted from the tribo CLI"));
  tribo::v1::AbortRunReply reply;
  try {
    tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
    reply = client.request(request).abort_run();
  } catch (const tribo::client::ClientError& e) {
    // Another client (e.g. `tribo run` in another terminal) holds control:
    // the abort itself carries the token (AbortRun.token), from an observer.
    if (e.error().code() != tribo::v1::PERMISSION_DENIED) throw;
    request.mutable_abort_run()->set_token(o.token);
    tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
    reply = client.request(request).abort_run();
  }
  std::cout << (o.json ? to_json(reply) + "\n" : "aborting run " + reply.run_id() + " (safe unload)\n");
  return kOk;
}

std::string annotations_text(const tribo::v1::RunAnnotations& a) {
  std::vector<std::string> parts;
  if (!a.sample().empty()) parts.push_back("sample=" + a.sample());
  if (!a.tip().empty()) parts.push_back("tip=" + a.tip());
  if (!a.operator_name().empty()) parts.push_back("operator=" + a.operator_name());
  std::map<std::string, std::string> extra(a.extra().begin(), a.extra().end());  // sorted
  for (const auto& [k, v] : extra) parts.push_back(k + "=" + v);
  if (!a.note().empty()) parts.push_back("note: " + a.note());
  return fmt::format("{}", fmt::join(parts, "  "));
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
    std::cout << fmt::format("{:<22} {:<10} {:>9} samples  {:<20} {}\n", r.run_id(),
                             r.finalized() ? tribo::v1::ExitStatus_Name(r.exit_status()) : "INCOMPLETE",
                             r.sample_count(), r.start_time_utc(), r.protocol_name());
    if (const std::string notes = annotations_text(r.annotations()); !notes.empty()) {
      std::cout << "    " << notes << "\n";
    }
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
  const std::string out = o.value("out").value_or(o.positional);
  if (auto refusal = refuse_overwrite(o, out)) return fail(o, *refusal, kUsage);
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  const tribo::wire::RecordedRun run = tribo::client::fetch_run(client, o.positional);
  std::string error;
  if (!tribo::wire::write_run_directory(out, run.metadata, run.samples, error)) return fail(o, error, kFailed);
  const auto saved = saved_run(run.metadata, out, static_cast<std::uint64_t>(tribo::sample_count(run.samples)));
  std::cout << (o.json ? to_json(saved) + "\n"
                       : "run " + saved.run_id() + " (" + saved.exit_status() + "): " +
                             std::to_string(saved.sample_count()) + " samples saved to " + out + "\n");
  return kOk;
}

int export_hdf5(const Options& o, const std::string& out) {
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  const tribo::wire::RecordedRun run = tribo::client::fetch_run(client, o.positional);
  std::string error;
  if (!tribo::client::write_run_hdf5(out, run, error)) return fail(o, error, kFailed);
  const auto saved = saved_run(run.metadata, out, static_cast<std::uint64_t>(tribo::sample_count(run.samples)));
  std::cout << (o.json ? to_json(saved) + "\n"
                       : std::to_string(saved.sample_count()) + " samples written to " + out + " (HDF5)\n");
  return kOk;
}

int export_command(const Options& o) {
  const auto out = o.value("out");
  const std::string format = o.value("format").value_or("csv");
  if (out) {
    if (auto refusal = refuse_overwrite(o, *out)) return fail(o, *refusal, kUsage);
  }
  if (format == "hdf5") {
    if (!out) return fail(o, "export --format hdf5 needs --out FILE.h5", kUsage);
    return export_hdf5(o, *out);
  }
  if (o.json && !out) return fail(o, "export --json needs --out FILE (stdout carries the CSV otherwise)", kUsage);
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::OBSERVER));
  tribo::v1::ClientMessage request;
  request.mutable_get_run()->set_run_id(o.positional);
  const tribo::v1::RunMetadata metadata = client.request(request).get_run().metadata();
  std::ofstream file;
  if (out) {
    file.open(*out, std::ios::binary | std::ios::trunc);
    if (!file) return fail(o, "cannot write " + *out, kFailed);
  }
  std::ostream& stream = out ? static_cast<std::ostream&>(file) : std::cout;
  const std::uint64_t rows = tribo::client::export_csv(client, o.positional, stream);
  stream.flush();
  if (!stream) return fail(o, "writing the CSV failed", kFailed);
  if (out) {
    const auto saved = saved_run(metadata, *out, rows);
    std::cout << (o.json ? to_json(saved) + "\n" : std::to_string(rows) + " samples written to " + *out + "\n");
  }
  return kOk;
}

int check_command(const Options& o) {
  const auto loaded = load_protocol(o);
  if (const auto* error = std::get_if<std::string>(&loaded)) return fail(o, *error, kUsage);
  const auto& protocol = std::get<tribo::v1::Protocol>(loaded);
  // The daemon's dry run: it validates against its own config and limits and
  // arms (nothing moves until a start).
  tribo::client::TriboClient client(o.address, session(o, tribo::v1::CONTROLLER));
  tribo::v1::ClientMessage load;
  *load.mutable_load_protocol()->mutable_protocol() = protocol;
  const tribo::v1::LoadProtocolReply reply = client.request(load).load_protocol();
  std::string plotted;
  if (const auto plot = o.value("plot")) {
    if (auto refusal = refuse_overwrite(o, *plot)) return fail(o, *refusal, kUsage);
    tribo::v1::DaemonConfig config;
    const std::string config_path = o.value("config").value_or("config/tribod.textproto");
    if (auto error = tribo::daemon::load_daemon_config(config_path, config)) {
      return fail(o, "--plot needs the daemon's config for the loop rate: " + *error + " (give --config FILE)", kUsage);
    }
    std::string error;
    if (!tribo::client::plot_planned_setpoints(protocol, config, *plot, error)) return fail(o, error, kFailed);
    plotted = *plot;
  }
  if (o.json) {
    std::cout << to_json(reply) << "\n";
    return kOk;
  }
  std::cout << fmt::format("protocol {} is valid: {:.3f} s, {} samples expected\n", reply.protocol_name(),
                           reply.duration_s(), reply.expected_samples());
  // The description says what the protocol needs (e.g. a gain change first).
  if (!protocol.description().empty()) std::cout << "description: " << protocol.description() << "\n";
  for (const auto& w : tribo::client::collapse_repeated(
           std::vector<std::string>(reply.warnings().begin(), reply.warnings().end()))) {
    std::cout << "warning: " << w << "\n";
  }
  if (reply.warnings().empty()) std::cout << "no warnings\n";
  if (!plotted.empty()) std::cout << "planned setpoints plotted to " << plotted << "\n";
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
  std::cout << fmt::format(
      "re-armed; setpoints re-synced to the instrument: lateral position {:.4f} µm, "
      "normal force {:.2f} µN, normal displacement {:.4f} µm (lateral force {:.2f} µN)\n",
      r.lateral_position_m() * 1e6, r.normal_force_n() * 1e6, r.normal_displacement_m() * 1e6,
      r.lateral_force_n() * 1e6);
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
  return fmt::format(
             "relay autotune of lateral-displacement: {} cycles, amplitude {:.4f} µm\n"
             "  ultimate gain Ku     {:g} N/m\n"
             "  ultimate period Pu   {:g} s\n"
             "  proposed ({}), {}:\n",
             r.cycles(), r.oscillation_amplitude_m() * 1e6, r.ultimate_gain_n_per_m(), r.ultimate_period_s(),
             r.rule(), r.applied() ? "applied" : "not applied (--apply applies them)") +
         tribo::client::gains_text(tribo::v1::LOOP_LATERAL_DISPLACEMENT, r.proposed(), "    ");
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

using Command = int (*)(const Options&);

// An option whose text goes into o.values[name]; the command checks it.
CLI::Option* value_option(CLI::App* app, Options& o, const std::string& name, const std::string& help) {
  return app->add_option_function<std::string>(
      "--" + name, [&o, name](const std::string& v) { o.values[name] = v; }, help);
}

// The command line's grammar: every command with its own options and --help.
void define_commands(CLI::App& app, Options& o, std::map<CLI::App*, Command>& commands) {
  app.add_flag("--json", o.json, "print JSON for scripts (protobuf field names; docs/cli.md)");
  app.add_option("--address", o.address_text,
                 "tribod's address HOST:PORT (default $TRIBO_ADDRESS or 127.0.0.1:7460)");
  app.add_option("--token", o.token,
                 "the daemon's control token for run, check, abort, set-gains, rearm and autotune "
                 "(default $TRIBO_TOKEN)");
  auto add = [&](const std::string& name, const std::string& help, Command command) {
    CLI::App* sub = app.add_subcommand(name, help);
    commands[sub] = command;
    return sub;
  };

  CLI::App* run = add("run",
                      "load the protocol, run it, stream the samples with a live progress line (on a "
                      "terminal), print the summary (friction in µN, mu, stiction peak, lag in µm)",
                      run_command);
  run->add_option("PROTOCOL", o.positional, "protocol file (protobuf text format)")->required();
  value_option(run, o, "out", "also save the run to this directory (refused if it exists, unless --force)");
  value_option(run, o, "seed", "noise seed of the simulated instrument");
  value_option(run, o, "friction-model",
               "compensate friction with this identified model: a `tribo-fit diagnose --json` report "
               "(docs/friction_compensation.md); replaces the protocol's own friction_compensation");
  run->add_flag("--progress,!--no-progress", o.progress, "draw the live progress line (default: on a terminal)");
  run->add_flag("--force", o.force, "replace an existing --out directory");
  value_option(run, o, "sample", "the sample, recorded with the run (shown by `tribo list`)");
  value_option(run, o, "tip", "the tip, recorded with the run");
  value_option(run, o, "operator", "who ran it, recorded with the run");
  value_option(run, o, "note", "a free-text note, recorded with the run");
  run->add_option("--meta", o.meta, "KEY=VALUE recorded with the run (repeatable)");
  run->footer("Ctrl-C aborts the run (safe unload), prints the summary and exits 130.");

  CLI::App* check = add("check",
                        "the daemon's dry run of a protocol: validation against its limits and every "
                        "warning, before anything moves (the protocol stays loaded)",
                        check_command);
  check->add_option("PROTOCOL", o.positional, "protocol file (protobuf text format)")->required();
  value_option(check, o, "friction-model", "check with this friction model report, as `run --friction-model`");
  value_option(check, o, "plot", "also plot the planned normal and lateral setpoints to this PNG");
  check->add_flag("--force", o.force, "replace an existing --plot file");
  value_option(check, o, "config", "the daemon's config, for the plot's loop rate (default config/tribod.textproto)");

  add("status", "the daemon's state, the current run, a safety trip's reason, recording and backend health",
      status_command);
  CLI::App* abort = add("abort",
                        "stop the running protocol (safe unload); works from another terminal while "
                        "`tribo run` holds control, given the token",
                        abort_command);
  value_option(abort, o, "reason", "why (recorded in the run's stop document)");
  CLI::App* list = add("list", "the recorded runs, newest first, with their sample, tip, operator and notes",
                       list_command);
  value_option(list, o, "max", "at most this many runs");
  CLI::App* fetch = add("fetch", "copy a recorded run (metadata.json, samples.csv) to a directory", fetch_command);
  fetch->add_option("RUN_ID", o.positional, "the run (see `tribo list`)")->required();
  value_option(fetch, o, "out", "the directory (default ./RUN_ID; refused if it exists, unless --force)");
  fetch->add_flag("--force", o.force, "replace an existing directory");
  CLI::App* exp = add("export", "a recorded run's samples as CSV (as recorded) or HDF5", export_command);
  exp->add_option("RUN_ID", o.positional, "the run (see `tribo list`)")->required();
  value_option(exp, o, "out", "the file (CSV default: stdout; refused if it exists, unless --force)");
  value_option(exp, o, "format", "csv (default) or hdf5 (channels as datasets with units, run documents as groups)")
      ->check(CLI::IsMember({"csv", "hdf5"}));
  exp->add_flag("--force", o.force, "replace an existing file");

  CLI::App* gains = add("gains",
                        "every loop's PID gains, SI units: the output is a drive force in N; kp N/m, ki N/(m s), "
                        "kd N s/m for the displacement loops, kp N/N, ki 1/s, kd s for the force loops",
                        gains_command);
  value_option(gains, o, "loop", "only this loop: " + tribo::client::loop_names());
  CLI::App* set_gains = add("set-gains",
                            "change only the given gains of LOOP (SI units, as for gains), also for a running "
                            "run (bumplessly); prints what the daemon applied",
                            set_gains_command);
  value_option(set_gains, o, "loop", "the loop: " + tribo::client::loop_names());
  for (std::string field : tribo::client::gain_fields()) {
    std::replace(field.begin(), field.end(), '_', '-');
    value_option(set_gains, o, field, "new value (SI)");
  }
  value_option(set_gains, o, "anti-windup", "anti-windup-none, back-calculation or conditional-integration");
  add("rearm", "leave FAULTED after a safety trip or an emergency stop", rearm_command);
  CLI::App* estop = add("estop",
                        "emergency stop: safe stop sequence, then FAULTED until rearm (any client may; "
                        "no control needed)",
                        estop_command);
  value_option(estop, o, "reason", "why (recorded with the fault)");
  CLI::App* autotune = add("autotune",
                           "relay autotune of the lateral displacement loop (not during a run): ultimate gain "
                           "and period, proposed gains",
                           autotune_command);
  value_option(autotune, o, "relay-amplitude-n", "relay amplitude, N");
  value_option(autotune, o, "hysteresis-m", "relay hysteresis, m");
  autotune->add_flag("--apply", o.apply, "apply the proposed gains");
}

bool wants_json(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--json") return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{kDescription, "tribo"};
  app.set_version_flag("--version", std::string("tribo ") + tribo::kSoftwareVersion);
  app.footer(kExitCodes);
  app.require_subcommand(1);
  app.fallthrough();  // --json, --address, --token also after the command
  Options options;
  std::map<CLI::App*, Command> commands;
  define_commands(app, options, commands);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    tribo::v1::Error error;
    error.set_code(tribo::v1::INVALID_ARGUMENT);
    error.set_message(std::string(e.what()) + " (see tribo --help)");
    return fail(wants_json(argc, argv), error, kUsage);
  }
  if (!options.address_text.empty()) {
    const auto address = tribo::client::parse_address(options.address_text);
    if (!address) {
      tribo::v1::Error error;
      error.set_code(tribo::v1::INVALID_ARGUMENT);
      error.set_message("--address " + options.address_text + " is not HOST:PORT");
      return fail(options.json, error, kUsage);
    }
    options.address = *address;
  }
  CLI::App* chosen = app.get_subcommands().front();
  options.command = chosen->get_name();
  try {
    return commands.at(chosen)(options);
  } catch (const tribo::client::ClientError& e) {
    return fail(options, e.error(), exit_code_of(e));
  }
}
