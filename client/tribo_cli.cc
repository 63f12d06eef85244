// tribo: the command-line client of tribod.
//
//   tribo run PROTOCOL.textproto [--out DIR] [--json] [--seed N] [--address HOST:PORT]
//
// Exit codes: 0 the run succeeded; 1 the run ended in ABORT or FAULT;
// 2 bad usage or an invalid protocol; 3 the daemon could not be reached or
// the connection failed.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>

#include "client/run_summary.h"
#include "client/tribo_client.h"
#include "proto/run_files.h"
#include "proto/text_format_file.h"
#include "tribo/v1/protocol.pb.h"

namespace {

constexpr const char* kUsageText =
    "usage: tribo run PROTOCOL.textproto [--out DIR] [--json] [--seed N] [--address HOST:PORT]\n"
    "  run         load the protocol into tribod, run it, stream the samples and\n"
    "              print a summary (friction in µN, mu, stiction peak, lag in µm)\n"
    "  --out DIR   also save the run there (samples.csv in SI units, metadata.json)\n"
    "  --json      print the summary as JSON (tribo.v1.RunSummary field names)\n"
    "  --seed N    noise seed for the simulated instrument\n"
    "  --address   tribod's address (default $TRIBO_ADDRESS or 127.0.0.1:7460)\n"
    "exit codes: 0 success, 1 run aborted or faulted, 2 usage or invalid protocol,\n"
    "            3 daemon unreachable\n";

enum ExitCode { kOk = 0, kRunFailed = 1, kUsage = 2, kConnection = 3 };

struct RunOptions {
  std::string protocol_path;
  std::optional<std::string> out_dir;
  bool json = false;
  std::optional<std::uint64_t> seed;
  tribo::client::Address address = tribo::client::default_address();
};

std::optional<RunOptions> parse_run_options(int argc, char** argv) {
  RunOptions o;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--json") {
      o.json = true;
    } else if (arg == "--out" && has_value) {
      o.out_dir = argv[++i];
    } else if (arg == "--seed" && has_value) {
      char* end = nullptr;
      o.seed = std::strtoull(argv[++i], &end, 10);
      if (*end != '\0') return std::nullopt;
    } else if (arg == "--address" && has_value) {
      const auto address = tribo::client::parse_address(argv[++i]);
      if (!address) return std::nullopt;
      o.address = *address;
    } else if (!arg.starts_with("--") && o.protocol_path.empty()) {
      o.protocol_path = arg;
    } else {
      return std::nullopt;
    }
  }
  if (o.protocol_path.empty()) return std::nullopt;
  return o;
}

int run_command(const RunOptions& o) {
  tribo::v1::Protocol protocol;
  if (auto error = tribo::wire::load_text_proto_file(o.protocol_path, protocol)) {
    std::cerr << "tribo: " << *error << "\n";
    return kUsage;
  }
  tribo::client::RunResult run;
  try {
    tribo::client::TriboClient client(o.address);
    run = tribo::client::run_protocol(client, protocol, o.seed);
  } catch (const tribo::client::ClientError& e) {
    std::cerr << "tribo: " << e.what() << "\n";
    const bool connection = e.error().field() == "connection";
    return connection ? kConnection : kUsage;
  }
  for (const auto& warning : run.loaded.warnings()) std::cerr << "tribo: warning: " << warning << "\n";
  if (run.missing_samples > 0) {
    std::cerr << "tribo: " << run.missing_samples
              << " samples did not reach this client; the daemon's recording has them all\n";
  }
  tribo::v1::RunSummary summary = tribo::client::summarize_run(run);
  if (o.out_dir) {
    tribo::v1::RunMetadata metadata;
    *metadata.mutable_start() = run.start;
    *metadata.mutable_stop() = run.stop;
    std::string error;
    if (!tribo::wire::write_run_directory(*o.out_dir, metadata, run.samples, error)) {
      std::cerr << "tribo: " << error << "\n";
      return kRunFailed;
    }
    summary.set_saved_to(*o.out_dir);
  }
  std::cout << (o.json ? tribo::client::summary_json(summary) + "\n"
                       : tribo::client::summary_text(summary));
  return run.stop.exit_status() == tribo::v1::SUCCESS ? kOk : kRunFailed;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << kUsageText;
    return kOk;
  }
  if (argc < 2 || std::string(argv[1]) != "run") {
    std::cerr << kUsageText;
    return kUsage;
  }
  const auto options = parse_run_options(argc, argv);
  if (!options) {
    std::cerr << kUsageText;
    return kUsage;
  }
  return run_command(*options);
}
