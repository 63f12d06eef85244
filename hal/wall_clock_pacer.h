// Paces a loop to absolute deadlines on CLOCK_MONOTONIC with
// clock_nanosleep(TIMER_ABSTIME): lateness is counted as an overrun and never
// accumulates (the next deadline is always start + k * period, skipping any
// deadlines already missed).
#pragma once

#include <cstdint>
#include <ctime>

namespace tribo::hal {

class WallClockPacer {
 public:
  explicit WallClockPacer(double period_s);

  // Sleeps until the next deadline.
  void wait();

  std::uint64_t overruns() const { return overruns_; }

 private:
  std::int64_t period_ns_;
  std::int64_t start_ns_;
  std::uint64_t tick_ = 0;
  std::uint64_t overruns_ = 0;
};

}  // namespace tribo::hal
