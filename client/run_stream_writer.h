// Writes a run's directory (proto/run_files.h layout) while the run streams,
// so that `tribo run` holds no more than one block of samples at a time (it
// used to keep every sample until the end: 489 MB an hour at 1 kHz).
//
// samples.csv is written row by row as blocks arrive, into samples.csv.tmp
// (created with O_EXCL | O_NOFOLLOW: a planted link is replaced, not
// followed). Row n must be the sample of sequence n, but a slow client gets
// gap notices instead of some blocks; those sequences are left out of the
// spool and remembered as holes. finish() fills the holes from the daemon's
// recording (fetched page by page) while copying the spool into the final
// file -- a second pass only when there were holes -- then fsyncs and renames
// it, and writes metadata.json the same way.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "proto/atomic_file.h"
#include "tribo/v1/api.pb.h"

namespace tribo::client {

class RunStreamWriter {
 public:
  // Creates dir (and its parents) and the spool in it. Returns false and
  // sets error when it cannot: before the run starts, nothing has moved.
  bool open(const std::filesystem::path& dir, std::string& error);

  // A streamed block, in arrival order: samples before the next expected
  // sequence are dropped (already written), a jump leaves a hole.
  bool append(const v1::SampleBlock& block);

  // Calls page(block) for the recorded samples [from, end), in pages.
  using FetchPages = std::function<void(std::uint64_t from, std::uint64_t end,
                                        const std::function<void(const v1::SampleBlock&)>& page)>;
  // Fills the holes and the tail up to end_sequence (the stop document's
  // sample count) with fetch, makes samples.csv and metadata.json. Returns
  // false and sets error on a write failure.
  bool finish(std::uint64_t end_sequence, const FetchPages& fetch, const v1::RunMetadata& metadata,
              std::string& error);

  struct Hole {
    std::uint64_t first = 0, end = 0;
  };
  const std::vector<Hole>& holes() const { return holes_; }
  std::uint64_t fetched_samples() const { return fetched_; }   // filled in from the recording
  std::uint64_t missing_samples() const { return missing_; }   // not there either
  std::uint64_t rows() const { return rows_; }                 // in samples.csv
  const std::filesystem::path& directory() const { return dir_; }
  // The most samples this writer held at once (the largest block or page):
  // the test hook for the client's memory.
  std::uint64_t peak_samples_held() const { return peak_held_; }

 private:
  bool write_rows(const v1::SampleBlock& block, int from_index, wire::AtomicFile& to);
  bool merge_holes(const FetchPages& fetch, std::string& error);

  std::filesystem::path dir_;
  wire::AtomicFile spool_;
  std::uint64_t next_ = 0;  // next sequence expected from the stream
  std::vector<Hole> holes_;
  std::uint64_t streamed_ = 0, fetched_ = 0, missing_ = 0, rows_ = 0, peak_held_ = 0;
  std::string row_;
};

}  // namespace tribo::client
