#include "proto/run_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>
#include <system_error>

#include <google/protobuf/util/json_util.h>

#include "proto/atomic_file.h"
#include "proto/sample_record.h"
#include "proto/text_format_file.h"

namespace tribo::wire {

namespace fs = std::filesystem;

std::string run_metadata_to_json(const v1::RunMetadata& metadata) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(metadata, &json, options);
  return json;
}

bool write_file_atomically(const fs::path& path, const std::string& content) {
  AtomicFile file;
  std::string error;
  return file.open(path, error) && file.write(content) && file.commit();
}

bool write_run_directory(const fs::path& dir, const v1::RunMetadata& metadata,
                         const v1::SampleBlock& samples, std::string& error) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    error = "cannot create " + dir.string() + ": " + ec.message();
    return false;
  }
  std::string csv = csv_header();
  for (int i = 0; i < sample_count(samples); ++i) append_csv_row(sample_at(samples, i), csv);
  if (!write_file_atomically(dir / kSamplesFile, csv) ||
      !write_file_atomically(dir / kMetadataFile, run_metadata_to_json(metadata))) {
    error = "cannot write into " + dir.string();
    return false;
  }
  return true;
}

namespace {

// Calls on_row(row, index, offset) for each complete data row of samples.csv
// (the header checked and skipped when starting at the beginning) until it
// returns false. Reads in chunks: a recording may be far larger than memory
// should hold. Can start at a known row's byte offset.
class CsvRows {
 public:
  explicit CsvRows(const fs::path& path) : file_(std::fopen(path.c_str(), "rb"), &std::fclose) {}

  bool open() const { return file_ != nullptr; }

  // Returns false if the header is missing or wrong, or the start cannot be reached.
  bool for_each(std::uint64_t start_row, std::uint64_t start_offset,
                const std::function<bool(std::string_view, std::uint64_t, std::uint64_t)>& on_row) {
    bool header = start_offset == 0;
    if (!header && std::fseek(file_.get(), static_cast<long>(start_offset), SEEK_SET) != 0) return false;
    std::string buffer;
    std::vector<char> chunk(1 << 16);  // 64 KiB: large reads, no page-faulting a fresh MiB per call
    std::uint64_t index = start_row;
    std::uint64_t buffer_offset = start_offset;  // file offset of buffer[0]
    std::size_t n;
    while ((n = std::fread(chunk.data(), 1, chunk.size(), file_.get())) > 0) {
      buffer.append(chunk.data(), n);
      std::size_t begin = 0;
      for (;;) {
        const void* nl = std::memchr(buffer.data() + begin, '\n', buffer.size() - begin);
        if (nl == nullptr) break;
        const std::size_t end = static_cast<std::size_t>(static_cast<const char*>(nl) - buffer.data());
        const std::string_view row(buffer.data() + begin, end - begin + 1);  // with the newline
        const std::uint64_t row_offset = buffer_offset + begin;
        begin = end + 1;
        if (header) {
          if (std::string(row) != csv_header()) return false;
          header = false;
          continue;
        }
        if (!on_row(row, index++, row_offset)) return true;
      }
      buffer.erase(0, begin);  // keeps a torn last line until more arrives, or forever
      buffer_offset += begin;
    }
    return !header;
  }

 private:
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
};

bool scan_rows(const fs::path& dir, SampleRange range,
               const std::function<bool(std::string_view)>& take, RowsRead& read,
               std::string& error, RowIndex* index) {
  CsvRows rows(dir / kSamplesFile);
  if (!rows.open()) {
    error = "cannot read " + (dir / kSamplesFile).string();
    return false;
  }
  const std::uint64_t end = range.max_samples == 0 || range.max_samples > ~range.from
                                ? ~std::uint64_t{0}
                                : range.from + range.max_samples;
  // Start from the last indexed row at or before the range.
  std::uint64_t start_row = 0, start_offset = 0;
  if (index != nullptr && !index->offsets.empty()) {
    const std::uint64_t k = std::min<std::uint64_t>(range.from / RowIndex::kStride, index->offsets.size() - 1);
    start_row = k * RowIndex::kStride;
    start_offset = index->offsets[k];
  }
  bool ok = true;
  read = RowsRead{0, true};
  const bool header_ok = rows.for_each(start_row, start_offset,
                                       [&](std::string_view row, std::uint64_t i, std::uint64_t offset) {
    if (index != nullptr && i % RowIndex::kStride == 0 && i / RowIndex::kStride == index->offsets.size()) {
      index->offsets.push_back(offset);
    }
    if (i >= end) {  // a row beyond the range: stop reading
      read.end_of_file = false;
      return false;
    }
    if (i >= range.from) {
      ok = take(row);
      ++read.rows;
    }
    return ok;
  });
  if (!header_ok) {
    error = "missing or unexpected header in " + (dir / kSamplesFile).string();
    return false;
  }
  if (!ok) {
    error = "malformed row in " + (dir / kSamplesFile).string();
    return false;
  }
  return true;
}

}  // namespace

bool read_csv_rows(const fs::path& dir, SampleRange range, std::string& csv, RowsRead& read,
                   std::string& error, RowIndex* index) {
  if (range.from == 0) csv += csv_header();
  return scan_rows(dir, range, [&](std::string_view row) {
    csv.append(row);
    return true;
  }, read, error, index);
}

bool read_sample_rows(const fs::path& dir, SampleRange range, v1::SampleBlock& block,
                      RowsRead& read, std::string& error, RowIndex* index) {
  block.set_first_sequence(range.from);
  return scan_rows(dir, range, [&](std::string_view row) {
    Sample s;
    if (!parse_csv_row(row.substr(0, row.size() - 1), s)) return false;
    append_sample(s, block);
    return true;
  }, read, error, index);
}

std::uint64_t count_recorded_samples(const fs::path& dir) {
  std::uint64_t count = 0;
  std::string error;
  RowsRead read;
  scan_rows(dir, SampleRange{}, [&](std::string_view) { ++count; return true; }, read, error, nullptr);
  return count;
}

std::optional<v1::RunMetadata> read_run_metadata(const fs::path& dir, std::string& error) {
  const auto json = read_file((dir / kMetadataFile).string());
  if (!json) {
    error = "cannot read " + (dir / kMetadataFile).string();
    return std::nullopt;
  }
  v1::RunMetadata metadata;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  if (!google::protobuf::util::JsonStringToMessage(*json, &metadata, options).ok()) {
    error = "malformed " + (dir / kMetadataFile).string();
    return std::nullopt;
  }
  return metadata;
}

std::optional<RecordedRun> read_run_directory(const fs::path& dir, std::string& error) {
  RecordedRun run;
  auto metadata = read_run_metadata(dir, error);
  if (!metadata) return std::nullopt;
  run.metadata = std::move(*metadata);
  RowsRead read;
  if (!read_sample_rows(dir, SampleRange{}, run.samples, read, error)) return std::nullopt;
  run.samples.set_run_id(run.metadata.start().run_id());
  return run;
}

bool is_valid_run_id(std::string_view run_id) {
  if (run_id.empty() || run_id.size() > 128 || run_id == "." || run_id == "..") return false;
  return std::all_of(run_id.begin(), run_id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
           c == '_' || c == '.';
  });
}

std::vector<fs::path> recorded_run_directories(const fs::path& data_dir) {
  std::vector<fs::path> dirs;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(data_dir, ec)) {
    if (entry.is_directory() && is_valid_run_id(entry.path().filename().string())) dirs.push_back(entry.path());
  }
  return dirs;
}

std::optional<v1::RunListing> read_run_listing(const fs::path& dir) {
  std::string error;
  const auto metadata = read_run_metadata(dir, error);
  if (!metadata) return std::nullopt;  // not a run directory
  v1::RunListing r;
  r.set_run_id(dir.filename().string());
  r.set_protocol_name(metadata->start().protocol().name());
  r.set_start_time_utc(metadata->start().start_time_utc());
  r.set_seed(metadata->start().seed());
  if (metadata->start().has_annotations()) *r.mutable_annotations() = metadata->start().annotations();
  r.set_finalized(metadata->has_stop());
  r.set_exit_status(metadata->stop().exit_status());
  r.set_reason(metadata->stop().reason());
  r.set_sample_count(metadata->has_stop() ? metadata->stop().sample_count() : count_recorded_samples(dir));
  return r;
}

void sort_newest_first(std::vector<v1::RunListing>& runs) {
  std::sort(runs.begin(), runs.end(), [](const auto& a, const auto& b) { return a.run_id() > b.run_id(); });
}

std::vector<v1::RunListing> list_recorded_runs(const fs::path& data_dir) {
  std::vector<v1::RunListing> runs;
  for (const auto& dir : recorded_run_directories(data_dir)) {
    if (auto listing = read_run_listing(dir)) runs.push_back(std::move(*listing));
  }
  sort_newest_first(runs);
  return runs;
}

}  // namespace tribo::wire
