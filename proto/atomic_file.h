// A file that appears whole or not at all: written (all at once, or
// incrementally as a run streams in) to a temporary beside it, made the file
// by commit() -- fsync, then rename over the target -- and removed if never
// committed. A stale or planted temporary (a symlink to a file elsewhere, say)
// is removed, not followed: unlink drops the link itself, and O_EXCL with
// O_NOFOLLOW creates a fresh file or fails.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace tribo::wire {

class AtomicFile {
 public:
  AtomicFile() = default;
  ~AtomicFile();  // not committed: the temporary goes
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Creates the temporary (default: path + ".tmp"). Returns false and sets
  // error if it cannot.
  bool open(const std::filesystem::path& path, std::string& error, std::filesystem::path temporary = {});
  // Buffers data; writes out whenever the buffer passes kBufferBytes.
  bool write(std::string_view data);
  // Writes out the buffer (the data is then readable with read()).
  bool flush();
  // Up to size bytes at offset of what was written so far (after flush());
  // returns the count, 0 at the end, -1 on error.
  long read(std::uint64_t offset, char* out, std::size_t size) const;
  // fsync and rename: the file is on disk under its name.
  bool commit();
  // Drops the temporary now.
  void discard();

  bool failed() const { return !error_.empty(); }
  // What failed first ("writing x: No space left on device").
  const std::string& error() const { return error_; }
  std::uint64_t bytes_written() const { return bytes_; }

  static constexpr std::size_t kBufferBytes = 1 << 20;

 private:
  bool fail(const std::string& what);

  std::filesystem::path path_, temporary_;
  int fd_ = -1;
  std::string buffer_;
  std::uint64_t bytes_ = 0;  // written to the file (not counting the buffer)
  std::string error_;
};

}  // namespace tribo::wire
