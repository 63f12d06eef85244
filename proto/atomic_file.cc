#include "proto/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

namespace tribo::wire {

namespace fs = std::filesystem;

AtomicFile::~AtomicFile() { discard(); }

bool AtomicFile::fail(const std::string& what) {
  if (error_.empty()) error_ = what + ": " + std::strerror(errno);
  return false;
}

bool AtomicFile::open(const fs::path& path, std::string& error, fs::path temporary) {
  discard();
  error_.clear();
  path_ = path;
  temporary_ = temporary.empty() ? fs::path(path.string() + ".tmp") : std::move(temporary);
  ::unlink(temporary_.c_str());
  fd_ = ::open(temporary_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    fail("creating " + temporary_.string());
    error = error_;
    return false;
  }
  return true;
}

bool AtomicFile::write(std::string_view data) {
  if (fd_ < 0 || failed()) return false;
  buffer_.append(data);
  return buffer_.size() < kBufferBytes || flush();
}

bool AtomicFile::flush() {
  if (fd_ < 0 || failed()) return false;
  std::size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return fail("writing " + temporary_.string());
    }
    done += static_cast<std::size_t>(n);
  }
  bytes_ += done;
  buffer_.clear();
  return true;
}

long AtomicFile::read(std::uint64_t offset, char* out, std::size_t size) const {
  if (fd_ < 0) return -1;
  for (;;) {
    const ssize_t n = ::pread(fd_, out, size, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    return static_cast<long>(n);
  }
}

bool AtomicFile::commit() {
  if (!flush()) return false;
  // On disk before the rename makes it the file: a crash leaves the old or the new, whole.
  if (::fsync(fd_) != 0) return fail("flushing " + temporary_.string());
  ::close(fd_);
  fd_ = -1;
  std::error_code ec;
  fs::rename(temporary_, path_, ec);
  if (ec) {
    error_ = "renaming " + temporary_.string() + ": " + ec.message();
    ::unlink(temporary_.c_str());
    return false;
  }
  return true;
}

void AtomicFile::discard() {
  if (fd_ < 0) return;
  ::close(fd_);
  fd_ = -1;
  ::unlink(temporary_.c_str());
  buffer_.clear();
}

}  // namespace tribo::wire
