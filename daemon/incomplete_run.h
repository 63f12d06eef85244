// What a start-up finds of a run the daemon did not finish (kill, crash,
// power): its directory has no stop document. samples.csv holds whole rows up
// to the last block that reached the disk, perhaps followed by a partial row
// (proto/run_files.h); everything after the last whole row is lost. The
// daemon comes up latched; this names the range that is missing, in the
// FAULTED reason and in a document left in that run's directory
// (incomplete.json), which readers of the run can show beside it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace tribo::daemon {

inline constexpr const char* kIncompleteRunFile = "incomplete.json";

struct IncompleteRun {
  std::string run_id;
  std::uint64_t whole_samples = 0;  // rows on disk that end in a newline
  bool partial_row = false;         // a row cut short follows them
  std::string reason;               // the FAULTED reason
  std::string document_error;       // why incomplete.json could not be written; empty: written
};

// The newest run under data_dir if it did not finish; writes its
// incomplete.json (detected_utc, last_whole_sequence, lost_from_sequence).
std::optional<IncompleteRun> find_incomplete_run(const std::filesystem::path& data_dir);

}  // namespace tribo::daemon
