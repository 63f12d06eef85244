#include "daemon/run_recorder.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <system_error>

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

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
    dir = data_dir / fmt::format("{}-{:03d}", stem, i);
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
  // Unbuffered: each block goes to the kernel in one write(2), so a failed
  // write is seen at once and the file can be cut back to whole rows.
  std::setvbuf(samples, nullptr, _IONBF, 0);
  const std::string header = csv_header();
  if (std::fwrite(header.data(), 1, header.size(), samples) != header.size() ||
      ::fsync(fileno(samples)) != 0) {
    error = "cannot write " + (dir / wire::kSamplesFile).string() + ": " + std::strerror(errno);
    return nullptr;
  }
  recorder->good_bytes_ = static_cast<long>(header.size());
  recorder->events_ = std::fopen((dir / kEventsFile).c_str(), "wb");
  if (recorder->events_ == nullptr) {
    error = "cannot create " + (dir / kEventsFile).string() + ": " + std::strerror(errno);
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
  if (events_ != nullptr) std::fclose(events_);
}

void RunRecorder::fail(const std::string& what) {
  if (write_failed_) return;
  write_failed_ = true;
  error_ = what;
}

void RunRecorder::describe(v1::RunDescriptor descriptor) {
  descriptor.set_run_id(metadata_.start().run_id());
  *metadata_.mutable_run_descriptor() = std::move(descriptor);
  if (!write_metadata()) fail("writing " + (directory_ / wire::kMetadataFile).string());
}

void RunRecorder::append(const Sample& sample) {
  ++appended_;
  if (write_failed_) return;  // the file ends at its last whole row
  append_csv_row(sample, block_);
  if (++block_samples_ >= kBlockSamples) flush();
}

void RunRecorder::flush() {
  if (block_samples_ == 0 || write_failed_) return;
  const int fd = fileno(samples_);
  const bool ok = std::fwrite(block_.data(), 1, block_.size(), samples_) == block_.size() && ::fsync(fd) == 0;
  if (ok) {
    good_bytes_ += static_cast<long>(block_.size());
    written_ += block_samples_;
  } else {
    fail("writing " + (directory_ / wire::kSamplesFile).string() + ": " + std::strerror(errno));
    // Cut the partial block off: the file keeps whole rows only.
    (void)!::ftruncate(fd, good_bytes_);
    std::fseek(samples_, good_bytes_, SEEK_SET);
  }
  block_.clear();
  block_samples_ = 0;
}

void RunRecorder::record(const v1::SegmentEvent& event) {
  *metadata_.add_segment_events() = event;
  if (events_ == nullptr || write_failed_) return;
  std::string line;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  (void)google::protobuf::util::MessageToJsonString(event, &line, options);
  line += '\n';
  if (std::fwrite(line.data(), 1, line.size(), events_) != line.size() || std::fflush(events_) != 0) {
    fail("writing " + (directory_ / kEventsFile).string() + ": " + std::strerror(errno));
  }
}

void RunRecorder::record(const v1::Fault& fault) {
  *metadata_.add_faults() = fault;
  if (!write_metadata()) fail("writing " + (directory_ / wire::kMetadataFile).string());
}

bool RunRecorder::write_metadata() {
  return wire::write_file_atomically(directory_ / wire::kMetadataFile,
                                     wire::run_metadata_to_json(metadata_));
}

bool RunRecorder::finish(const v1::RunStop& stop) {
  flush();
  *metadata_.mutable_stop() = stop;
  // The stop document is written even after a failed sample write: it says
  // which samples are missing (it is small, and may still fit).
  const bool metadata_ok = write_metadata();
  if (!metadata_ok) fail("writing " + (directory_ / wire::kMetadataFile).string());
  if (::fsync(fileno(samples_)) != 0 && !write_failed_) fail("fsync of samples.csv: " + std::string(std::strerror(errno)));
  return !write_failed_;
}

}  // namespace tribo::daemon
