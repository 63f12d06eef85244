// The on-disk layout of a recorded run, shared by the daemon's recorder, the
// client's --out and the analysis tools:
//   <dir>/metadata.json   tribo.v1.RunMetadata as JSON (proto field names)
//   <dir>/samples.csv     csv_header() then one row per sample (proto/sample_record.h)
// samples.csv only grows, by whole rows; a reader counts only rows that end in
// a newline, so a file cut short by a crash reads back up to its last row.
// Row n (0-based, after the header) holds the sample of sequence number n.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

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

// A run id names a directory directly under the data directory: no path
// separators, no "." or "..", printable ASCII only.
bool is_valid_run_id(std::string_view run_id);

std::optional<v1::RunMetadata> read_run_metadata(const std::filesystem::path& dir, std::string& error);

// Complete rows in dir/samples.csv now.
std::uint64_t count_recorded_samples(const std::filesystem::path& dir);

// Rows [from, from + max_samples) of dir/samples.csv (max_samples 0: to the
// end), as raw text (with the header line first when from is 0) or parsed into
// a SampleBlock (first_sequence = from). Returns false and sets error if the
// file cannot be read or a row is malformed.
struct SampleRange {
  std::uint64_t from = 0;
  std::uint64_t max_samples = 0;
};
struct RowsRead {
  std::uint64_t rows = 0;         // rows taken
  bool end_of_file = false;       // no complete row after them
};
// Byte offsets of every kStride-th row of one samples.csv, filled in as rows
// are read, so that paging through a long recording does not rescan it from
// the start. Valid as long as the file only grows (it does).
struct RowIndex {
  static constexpr std::uint64_t kStride = 8192;
  std::vector<std::uint64_t> offsets;  // offsets[k]: row k * kStride
};
bool read_csv_rows(const std::filesystem::path& dir, SampleRange range, std::string& csv,
                   RowsRead& read, std::string& error, RowIndex* index = nullptr);
bool read_sample_rows(const std::filesystem::path& dir, SampleRange range, v1::SampleBlock& block,
                      RowsRead& read, std::string& error, RowIndex* index = nullptr);

// The recorded runs under data_dir, newest first (run ids sort by time).
std::vector<v1::RunListing> list_recorded_runs(const std::filesystem::path& data_dir);

// The pieces of list_recorded_runs, for a caller that keeps listings between
// calls: the directories named by a valid run id (unordered), one run's listing
// (nullopt if dir holds no readable metadata.json), and the listing order.
std::vector<std::filesystem::path> recorded_run_directories(const std::filesystem::path& data_dir);
std::optional<v1::RunListing> read_run_listing(const std::filesystem::path& dir);
void sort_newest_first(std::vector<v1::RunListing>& runs);

}  // namespace tribo::wire
