// Paces a loop to absolute deadlines on CLOCK_MONOTONIC: lateness is counted
// as an overrun and never accumulates (the next deadline is always
// start + k * period, skipping any deadlines already missed).
//
// The sleep is interruptible (hal/tick_wake.h): a wake ends it early, so the
// loop acts on an emergency stop as soon as it is posted instead of at the
// next deadline. The woken tick is taken early; the deadlines after it stay
// on the same grid (start + k * period).
#pragma once

#include <cstdint>
#include <ctime>

#include "hal/tick_wake.h"

namespace tribo::hal {

class WallClockPacer {
 public:
  // wake may be null (then the sleep is not interruptible); it must outlive
  // the pacer.
  explicit WallClockPacer(double period_s, TickWake* wake = nullptr);

  // Sleeps until the next deadline; true if a wake ended the sleep early.
  bool wait();

  std::uint64_t overruns() const { return overruns_; }

 private:
  std::int64_t period_ns_;
  std::int64_t start_ns_;
  TickWake* wake_;
  std::uint64_t tick_ = 0;
  std::uint64_t overruns_ = 0;
};

}  // namespace tribo::hal
