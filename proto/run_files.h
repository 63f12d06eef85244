// The on-disk layout of a recorded run, shared by the daemon's recorder, the
// client's --out and the analysis tools:
//   <dir>/metadata.json   tribo.v1.RunMetadata as JSON (proto field names)
//   <dir>/samples.csv     csv_header() then one row per sample (proto/sample_record.h)
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "tribo/v1/api.pb.h"

namespace tribo::wire {

inline constexpr const char* kMetadataFile = "metadata.json";
inline constexpr const char* kSamplesFile = "samples.csv";

std::string run_metadata_to_json(const v1::RunMetadata& metadata);

// Writes dir/<name> via a temporary file and rename, so readers never see half a file.
bool write_file_atomically(const std::filesystem::path& path, const std::string& content);

// Writes a complete run (creating dir). Returns false and sets error on failure.
bool write_run_directory(const std::filesystem::path& dir, const v1::RunMetadata& metadata,
                         const v1::SampleBlock& samples, std::string& error);

struct RecordedRun {
  v1::RunMetadata metadata;
  v1::SampleBlock samples;
};

// Reads a run back; a torn last line (a crash mid-write) ends the samples.
std::optional<RecordedRun> read_run_directory(const std::filesystem::path& dir, std::string& error);

}  // namespace tribo::wire
