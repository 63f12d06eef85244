#include "hal/tick_wake.h"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>

namespace tribo::hal {

namespace {

// FUTEX_WAIT_BITSET takes an absolute timeout on CLOCK_MONOTONIC (without
// FUTEX_CLOCK_REALTIME), so a wait cut short by a signal resumes towards
// the same deadline; FUTEX_WAIT would take a relative one.
long futex(std::atomic<std::uint32_t>* word, int op, std::uint32_t value, const timespec* timeout) {
  static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t));
  return syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(word), op | FUTEX_PRIVATE_FLAG, value, timeout,
                 nullptr, FUTEX_BITSET_MATCH_ANY);
}

}  // namespace

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool TickWake::wait_until(std::int64_t deadline_ns) {
  timespec ts{};
  ts.tv_sec = deadline_ns / 1'000'000'000;
  ts.tv_nsec = deadline_ns % 1'000'000'000;
  for (;;) {
    if (word_.exchange(0, std::memory_order_acquire) != 0) {
      wakes_.fetch_add(1, std::memory_order_relaxed);
      return true;
    }
    // Sleeps only while the word is still 0: a wake() between the exchange
    // above and this call makes it return EAGAIN at once.
    if (futex(&word_, FUTEX_WAIT_BITSET, 0, &ts) != 0 && errno == ETIMEDOUT) {
      // A wake racing with the deadline still counts: it is not left pending
      // to cut the next period short for nothing.
      if (word_.exchange(0, std::memory_order_acquire) != 0) {
        wakes_.fetch_add(1, std::memory_order_relaxed);
        return true;
      }
      return false;
    }
    // Woken, EAGAIN (a wake came first) or EINTR: look at the word again.
  }
}

void TickWake::wake() {
  word_.store(1, std::memory_order_release);
  futex(&word_, FUTEX_WAKE, 1, nullptr);
}

}  // namespace tribo::hal
