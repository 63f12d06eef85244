#include "client/run_stream_writer.h"

#include <algorithm>
#include <cstring>
#include <system_error>

#include "proto/run_files.h"
#include "proto/sample_record.h"

namespace tribo::client {

namespace fs = std::filesystem;

namespace {

// Copies whole lines of the spool, in order, into another file.
class LineCopier {
 public:
  explicit LineCopier(const wire::AtomicFile& from) : from_(from) {}

  // Copies up to n lines; returns how many there were.
  std::uint64_t copy(std::uint64_t n, wire::AtomicFile& to) {
    std::uint64_t copied = 0;
    while (copied < n) {
      const char* begin = buffer_.data() + pos_;
      const void* nl = std::memchr(begin, '\n', buffer_.size() - pos_);
      if (nl == nullptr) {
        if (!refill()) break;
        continue;
      }
      const std::size_t length = static_cast<std::size_t>(static_cast<const char*>(nl) - begin) + 1;
      to.write(std::string_view(begin, length));
      pos_ += length;
      ++copied;
    }
    return copied;
  }

 private:
  bool refill() {
    buffer_.erase(0, pos_);
    pos_ = 0;
    const std::size_t had = buffer_.size();
    buffer_.resize(had + kChunk);
    const long n = from_.read(offset_, buffer_.data() + had, kChunk);
    buffer_.resize(had + static_cast<std::size_t>(std::max(0L, n)));
    if (n <= 0) return false;
    offset_ += static_cast<std::uint64_t>(n);
    return true;
  }

  static constexpr std::size_t kChunk = 1 << 20;
  const wire::AtomicFile& from_;
  std::string buffer_;
  std::size_t pos_ = 0;
  std::uint64_t offset_ = 0;
};

}  // namespace

bool RunStreamWriter::open(const fs::path& dir, std::string& error) {
  dir_ = dir;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    error = "cannot create " + dir.string() + ": " + ec.message();
    return false;
  }
  if (!spool_.open(dir / wire::kSamplesFile, error)) return false;
  return spool_.write(csv_header());
}

bool RunStreamWriter::write_rows(const v1::SampleBlock& block, int from_index, wire::AtomicFile& to) {
  for (int i = from_index; i < sample_count(block); ++i) {
    row_.clear();
    append_csv_row(sample_at(block, i), row_);
    to.write(row_);
  }
  return !to.failed();
}

bool RunStreamWriter::append(const v1::SampleBlock& block) {
  const auto n = static_cast<std::uint64_t>(sample_count(block));
  peak_held_ = std::max(peak_held_, n);
  const std::uint64_t first = block.first_sequence(), end = first + n;
  if (n == 0 || end <= next_) return !spool_.failed();
  if (first > next_) holes_.push_back({next_, first});  // a gap notice: the recording has them
  const std::uint64_t skip = first < next_ ? next_ - first : 0;
  streamed_ += n - skip;
  next_ = end;
  return write_rows(block, static_cast<int>(skip), spool_);
}

bool RunStreamWriter::merge_holes(const FetchPages& fetch, std::string& error) {
  if (!spool_.flush()) {
    error = spool_.error();
    return false;
  }
  wire::AtomicFile out;
  if (!out.open(dir_ / wire::kSamplesFile, error, dir_ / "samples.csv.merge.tmp")) return false;
  LineCopier spool(spool_);
  spool.copy(1, out);  // the header
  std::uint64_t sequence = 0;
  for (const Hole& hole : holes_) {
    spool.copy(hole.first - sequence, out);
    std::uint64_t got = 0;
    fetch(hole.first, hole.end, [&](const v1::SampleBlock& page) {
      const auto n = static_cast<std::uint64_t>(sample_count(page));
      peak_held_ = std::max(peak_held_, n);
      got += n;
      write_rows(page, 0, out);
    });
    const std::uint64_t wanted = hole.end - hole.first;
    fetched_ += std::min(got, wanted);
    missing_ += got < wanted ? wanted - got : 0;
    sequence = hole.end;
  }
  spool.copy(~std::uint64_t{0}, out);
  rows_ = streamed_ + fetched_;
  if (!out.commit()) {
    error = out.error();
    return false;
  }
  spool_.discard();
  return true;
}

bool RunStreamWriter::finish(std::uint64_t end_sequence, const FetchPages& fetch, const v1::RunMetadata& metadata,
                             std::string& error) {
  if (end_sequence > next_) holes_.push_back({next_, end_sequence});  // the stream's tail, if it missed it
  next_ = std::max(next_, end_sequence);
  if (spool_.failed()) {
    error = spool_.error();
    return false;
  }
  if (holes_.empty()) {
    rows_ = streamed_;
    if (!spool_.commit()) {
      error = spool_.error();
      return false;
    }
  } else if (!merge_holes(fetch, error)) {
    return false;
  }
  if (!wire::write_file_atomically(dir_ / wire::kMetadataFile, wire::run_metadata_to_json(metadata))) {
    error = "cannot write " + (dir_ / wire::kMetadataFile).string();
    return false;
  }
  return true;
}

}  // namespace tribo::client
