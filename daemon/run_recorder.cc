#include "daemon/run_recorder.h"

#include <ctime>
#include <system_error>

#include "proto/run_files.h"

namespace tribo::daemon {

namespace fs = std::filesystem;

namespace {

std::string utc_now(const char* format) {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buf[32];
  std::strftime(buf, sizeof buf, format, &utc);
  return buf;
}

}  // namespace

std::string utc_timestamp_iso8601() { return utc_now("%Y-%m-%dT%H:%M:%SZ"); }

std::unique_ptr<RunRecorder> RunRecorder::create(const fs::path& data_dir, v1::RunStart& start,
                                                 std::string& error) {
  std::error_code ec;
  fs::create_directories(data_dir, ec);
  if (ec) {
    error = "cannot create data directory " + data_dir.string() + ": " + ec.message();
    return nullptr;
  }
  const std::string stem = utc_now("%Y%m%d-%H%M%S");
  fs::path dir;
  for (int i = 0; i < 1000; ++i) {
    char suffix[8];
    std::snprintf(suffix, sizeof suffix, "-%03d", i);
    dir = data_dir / (stem + suffix);
    if (fs::create_directory(dir, ec)) break;  // atomic: two daemons never share a run
    dir.clear();
  }
  if (dir.empty()) {
    error = "cannot create a run directory under " + data_dir.string();
    return nullptr;
  }
  start.set_run_id(dir.filename().string());
  std::FILE* samples = std::fopen((dir / wire::kSamplesFile).c_str(), "wb");
  if (samples == nullptr) {
    error = "cannot create " + (dir / wire::kSamplesFile).string();
    return nullptr;
  }
  v1::RunMetadata metadata;
  *metadata.mutable_start() = start;
  std::unique_ptr<RunRecorder> recorder(new RunRecorder(dir, samples, std::move(metadata)));
  if (!recorder->write_metadata()) {
    error = "cannot write " + (dir / wire::kMetadataFile).string();
    return nullptr;
  }
  const std::string header = csv_header();
  if (std::fwrite(header.data(), 1, header.size(), samples) != header.size() ||
      std::fflush(samples) != 0) {
    error = "cannot write " + (dir / wire::kSamplesFile).string();
    return nullptr;
  }
  return recorder;
}

RunRecorder::RunRecorder(fs::path directory, std::FILE* samples, v1::RunMetadata metadata)
    : directory_(std::move(directory)), samples_(samples), metadata_(std::move(metadata)) {
  block_.reserve(kBlockSamples * 160);
}

RunRecorder::~RunRecorder() {
  if (samples_ != nullptr) std::fclose(samples_);
}

void RunRecorder::describe(v1::RunDescriptor descriptor) {
  descriptor.set_run_id(metadata_.start().run_id());
  *metadata_.mutable_run_descriptor() = std::move(descriptor);
  if (!write_metadata()) write_failed_ = true;
}

void RunRecorder::append(const Sample& sample) {
  append_csv_row(sample, block_);
  if (++block_samples_ >= kBlockSamples) flush();
}

void RunRecorder::flush() {
  if (block_samples_ == 0) return;
  if (std::fwrite(block_.data(), 1, block_.size(), samples_) != block_.size()) write_failed_ = true;
  if (std::fflush(samples_) != 0) write_failed_ = true;
  block_.clear();
  block_samples_ = 0;
}

void RunRecorder::record(const v1::SegmentEvent& event) {
  *metadata_.add_segment_events() = event;
  if (!write_metadata()) write_failed_ = true;
}

void RunRecorder::record(const v1::Fault& fault) {
  *metadata_.add_faults() = fault;
  if (!write_metadata()) write_failed_ = true;
}

bool RunRecorder::write_metadata() {
  return wire::write_file_atomically(directory_ / wire::kMetadataFile,
                                     wire::run_metadata_to_json(metadata_));
}

bool RunRecorder::finish(const v1::RunStop& stop) {
  flush();
  *metadata_.mutable_stop() = stop;
  if (!write_metadata()) write_failed_ = true;
  return !write_failed_;
}

}  // namespace tribo::daemon
