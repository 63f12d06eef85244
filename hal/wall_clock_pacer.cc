#include "hal/wall_clock_pacer.h"

#include <cmath>

namespace tribo::hal {

WallClockPacer::WallClockPacer(double period_s, TickWake* wake)
    : period_ns_(static_cast<std::int64_t>(std::llround(period_s * 1e9))), start_ns_(monotonic_ns()), wake_(wake) {}

bool WallClockPacer::wait() {
  ++tick_;
  std::int64_t deadline = start_ns_ + static_cast<std::int64_t>(tick_) * period_ns_;
  const std::int64_t now = monotonic_ns();
  if (now > deadline) {
    ++overruns_;
    // Skip the deadlines already missed instead of running them back to back.
    const auto missed = static_cast<std::uint64_t>((now - deadline) / period_ns_) + 1;
    tick_ += missed;
    deadline = start_ns_ + static_cast<std::int64_t>(tick_) * period_ns_;
  }
  if (wake_ != nullptr) return wake_->wait_until(deadline);
  timespec ts{};
  ts.tv_sec = deadline / 1'000'000'000;
  ts.tv_nsec = deadline % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {
  }
  return false;
}

}  // namespace tribo::hal
