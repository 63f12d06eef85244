#include "daemon/incomplete_run.h"

#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "daemon/run_recorder.h"
#include "proto/run_files.h"

namespace tribo::daemon {

namespace fs = std::filesystem;

namespace {

// samples.csv ends in something other than a newline: a row cut short.
bool ends_in_partial_row(const fs::path& samples) {
  std::ifstream in(samples, std::ios::binary | std::ios::ate);
  if (!in || in.tellg() <= 0) return false;
  in.seekg(-1, std::ios::end);
  char last = '\n';
  in.get(last);
  return last != '\n';
}

}  // namespace

std::optional<IncompleteRun> find_incomplete_run(const fs::path& data_dir) {
  const auto runs = wire::list_recorded_runs(data_dir);
  if (runs.empty() || runs.front().finalized()) return std::nullopt;
  const fs::path dir = data_dir / runs.front().run_id();
  IncompleteRun r;
  r.run_id = runs.front().run_id();
  r.whole_samples = wire::count_recorded_samples(dir);
  r.partial_row = ends_in_partial_row(dir / wire::kSamplesFile);
  // Sequence numbers are row numbers (0-based): the last whole one is
  // whole_samples - 1; every sample from whole_samples on is lost.
  const std::string recorded =
      r.whole_samples == 0 ? std::string("no whole sample reached the disk, so every sample is lost")
                           : fmt::format("the last whole sample recorded is sequence {}; every sample after it "
                                         "(from sequence {} on) is lost",
                                         r.whole_samples - 1, r.whole_samples);
  r.reason = fmt::format(
      "the previous run {} did not finish (no stop document): the daemon stopped during it and the instrument's "
      "state is unknown; {}{}; check the instrument and re-arm",
      r.run_id, recorded, r.partial_row ? " (a partial last row is not counted)" : "");

  nlohmann::json doc;
  doc["run_id"] = r.run_id;
  doc["detected_utc"] = utc_timestamp_iso8601();
  doc["whole_samples"] = r.whole_samples;
  doc["last_whole_sequence"] = r.whole_samples == 0 ? nlohmann::json(nullptr) : nlohmann::json(r.whole_samples - 1);
  doc["lost_from_sequence"] = r.whole_samples;
  doc["partial_last_row"] = r.partial_row;
  doc["reason"] = r.reason;
  if (!wire::write_file_atomically(dir / kIncompleteRunFile, doc.dump(2) + "\n")) {
    r.document_error = "cannot write " + (dir / kIncompleteRunFile).string();
  }
  return r;
}

}  // namespace tribo::daemon
