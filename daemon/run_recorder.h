// Records one run to disk in the layout of proto/run_files.h: samples.csv is
// append-only, written in blocks of whole rows, each block fsync'ed before the
// samples in it are published, so every sample a client has seen is on disk.
// metadata.json is written at start (with the descriptor), rewritten at a
// fault (at most once a run) and finalized once with the stop document;
// segment events are appended to events.jsonl as they happen (one line each,
// O(1) per event: rewriting the whole metadata per event made long protocols
// cost O(n^2)) and go into metadata.json at the end. A run cut short by a
// crash or a kill is readable up to its last fsync'ed block.
//
// A failed write (full disk, I/O error) is never silent: the file is cut
// back to its last whole row, nothing more is written to it, and the range
// of samples that did not reach the disk is kept for the stop document.
#pragma once

#include <cstdint>
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
  // What failed first ("writing samples.csv: No space left on device").
  const std::string& error() const { return error_; }
  // Samples appended so far, and those of them that reached the disk.
  std::uint64_t appended() const { return appended_; }
  std::uint64_t written() const { return written_; }

  static constexpr const char* kEventsFile = "events.jsonl";

 private:
  void fail(const std::string& what);
  RunRecorder(std::filesystem::path directory, std::FILE* samples, v1::RunMetadata metadata);
  bool write_metadata();

  static constexpr std::size_t kBlockSamples = 4096;
  std::filesystem::path directory_;
  std::FILE* samples_;
  v1::RunMetadata metadata_;
  std::string block_;
  std::size_t block_samples_ = 0;
  bool write_failed_ = false;
  std::string error_;
  std::uint64_t appended_ = 0, written_ = 0;
  long good_bytes_ = 0;      // samples.csv up to its last whole, written row
  std::FILE* events_ = nullptr;
};

std::string utc_timestamp_iso8601();

}  // namespace tribo::daemon
