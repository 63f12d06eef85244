// Runtime of the stages of the real-time tick, kept by the loop thread and
// published through relaxed atomics for status requests (a reader may see the
// stages of slightly different ticks; each value is itself consistent).
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <string_view>

namespace tribo::daemon {

enum class Stage : std::uint8_t { kRead, kSupervise, kControl, kWrite, kRecord, kTick };
constexpr std::size_t kStageCount = 6;

constexpr std::string_view stage_name(Stage s) {
  constexpr std::array<std::string_view, kStageCount> names{"read", "supervise", "control",
                                                            "write", "record", "tick"};
  return names[static_cast<std::size_t>(s)];
}

struct StageSnapshot {
  std::uint64_t last_ns = 0;
  std::uint64_t max_ns = 0;
  std::uint64_t total_ns = 0;
};

class TickTiming {
 public:
  // Loop thread only.
  void record(Stage stage, std::uint64_t ns) {
    Local& l = local_[static_cast<std::size_t>(stage)];
    l.max = ns > l.max ? ns : l.max;
    l.total += ns;
    Shared& s = shared_[static_cast<std::size_t>(stage)];
    s.last_ns.store(ns, std::memory_order_relaxed);
    s.max_ns.store(l.max, std::memory_order_relaxed);
    s.total_ns.store(l.total, std::memory_order_relaxed);
  }
  void count_tick() { ticks_.store(++local_ticks_, std::memory_order_relaxed); }

  // Any thread.
  StageSnapshot snapshot(Stage stage) const {
    const Shared& s = shared_[static_cast<std::size_t>(stage)];
    return {s.last_ns.load(std::memory_order_relaxed), s.max_ns.load(std::memory_order_relaxed),
            s.total_ns.load(std::memory_order_relaxed)};
  }
  std::uint64_t ticks() const { return ticks_.load(std::memory_order_relaxed); }

 private:
  struct Local {
    std::uint64_t max = 0;
    std::uint64_t total = 0;
  };
  struct Shared {
    std::atomic<std::uint64_t> last_ns{0};
    std::atomic<std::uint64_t> max_ns{0};
    std::atomic<std::uint64_t> total_ns{0};
  };
  std::array<Local, kStageCount> local_{};
  std::array<Shared, kStageCount> shared_{};
  std::uint64_t local_ticks_ = 0;
  std::atomic<std::uint64_t> ticks_{0};
};

// Monotonic nanoseconds (vDSO clock_gettime: no system call, no allocation).
inline std::uint64_t monotonic_ns() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(
          std::chrono::steady_clock::now().time_since_epoch())
          .count());
}

}  // namespace tribo::daemon
