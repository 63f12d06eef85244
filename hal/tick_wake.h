// Ends a paced loop's sleep early: the loop thread waits on a futex word
// until an absolute CLOCK_MONOTONIC deadline (FUTEX_WAIT_BITSET), and any
// other thread can cut that wait short with wake() (FUTEX_WAKE). An
// emergency stop posted by the API thread is then acted on as soon as it
// arrives, not at the next deadline.
//
// A wake is not lost when the loop is not waiting: it stays pending and the
// next wait returns at once. One wake ends one wait. Neither side allocates
// or takes a lock; wake() is async-signal-safe.
#pragma once

#include <atomic>
#include <cstdint>

namespace tribo::hal {

class TickWake {
 public:
  // Blocks until deadline_ns (CLOCK_MONOTONIC, absolute) or a wake; true if
  // a wake ended it (also when one was already pending), false at the deadline.
  bool wait_until(std::int64_t deadline_ns);
  // Safe from any thread.
  void wake();
  // Wakes delivered to a wait so far (for tests and diagnostics).
  std::uint64_t wakes() const { return wakes_.load(std::memory_order_relaxed); }

 private:
  // 0: nothing pending; 1: a wake is pending. A futex word must be 32 bits.
  std::atomic<std::uint32_t> word_{0};
  std::atomic<std::uint64_t> wakes_{0};
};

// CLOCK_MONOTONIC now, in ns (the clock of the deadlines).
std::int64_t monotonic_ns();

}  // namespace tribo::hal
