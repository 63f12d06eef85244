#include "proto/run_files.h"

#include <fstream>
#include <system_error>

#include <google/protobuf/util/json_util.h>

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
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out << content;
    out.flush();
    if (!out) return false;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  return !ec;
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

std::optional<RecordedRun> read_run_directory(const fs::path& dir, std::string& error) {
  RecordedRun run;
  const auto json = read_file((dir / kMetadataFile).string());
  if (!json) {
    error = "cannot read " + (dir / kMetadataFile).string();
    return std::nullopt;
  }
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  if (!google::protobuf::util::JsonStringToMessage(*json, &run.metadata, options).ok()) {
    error = "malformed " + (dir / kMetadataFile).string();
    return std::nullopt;
  }
  std::ifstream in(dir / kSamplesFile);
  std::string line;
  if (!std::getline(in, line) || line + '\n' != csv_header()) {
    error = "missing or unexpected header in " + (dir / kSamplesFile).string();
    return std::nullopt;
  }
  Sample s;
  while (std::getline(in, line)) {
    if (!parse_csv_row(line, s)) break;
    append_sample(s, run.samples);
  }
  run.samples.set_run_id(run.metadata.start().run_id());
  return run;
}

}  // namespace tribo::wire
