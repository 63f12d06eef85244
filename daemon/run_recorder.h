// Records one run to disk in the layout of proto/run_files.h: samples.csv is
// append-only, written in blocks of whole rows and flushed after each;
// metadata.json is written at start (with the descriptor), rewritten
// atomically at each segment event and fault, and with the stop document at
// the end. A run cut short by a crash or a kill is readable up to its last
// flushed block. The drain thread flushes before it publishes samples, so
// every sample a client has seen can be fetched back from the file.
#pragma once

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "proto/sample_record.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

class RunRecorder {
 public:
  // Creates a fresh directory under data_dir named after the UTC time (with a
  // counter if taken), stores the run id in start, writes the metadata.
  static std::unique_ptr<RunRecorder> create(const std::filesystem::path& data_dir,
                                             v1::RunStart& start, std::string& error);
  ~RunRecorder();

  // Stores the descriptor (run_id is set here) and rewrites the metadata.
  void describe(v1::RunDescriptor descriptor);
  void append(const Sample& sample);
  // Writes the buffered rows and flushes them to the OS.
  void flush();
  void record(const v1::SegmentEvent& event);
  void record(const v1::Fault& fault);
  // Flushes the samples and writes the final metadata. Returns false on a write error.
  bool finish(const v1::RunStop& stop);

  const std::filesystem::path& directory() const { return directory_; }
  bool write_failed() const { return write_failed_; }

 private:
  RunRecorder(std::filesystem::path directory, std::FILE* samples, v1::RunMetadata metadata);
  bool write_metadata();

  static constexpr std::size_t kBlockSamples = 4096;
  std::filesystem::path directory_;
  std::FILE* samples_;
  v1::RunMetadata metadata_;
  std::string block_;
  std::size_t block_samples_ = 0;
  bool write_failed_ = false;
};

std::string utc_timestamp_iso8601();

}  // namespace tribo::daemon
