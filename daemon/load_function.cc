#include "daemon/load_function.h"

namespace tribo::daemon {

LoadFunction::LoadFunction(std::vector<SegmentPlan> segments, double loop_rate_hz)
    : segments_(std::move(segments)), loop_rate_hz_(loop_rate_hz) {
  for (const SegmentPlan& s : segments_) total_ticks_ += s.tick_count;
}

std::uint64_t LoadFunction::expected_samples() const {
  std::uint64_t samples = 0;
  for (const SegmentPlan& s : segments_) samples += s.tick_count / s.ticks_per_sample;
  return samples;
}

Setpoints LoadFunction::at(std::uint64_t tick, std::size_t& cursor) const {
  while (cursor + 1 < segments_.size() &&
         tick >= segments_[cursor].start_tick + segments_[cursor].tick_count) {
    ++cursor;
  }
  const SegmentPlan& s = segments_[cursor];
  // Linear within the segment: begin at its first tick, end at the next
  // segment's first tick.
  const double fraction =
      static_cast<double>(tick - s.start_tick) / static_cast<double>(s.tick_count);
  return Setpoints{static_cast<std::uint32_t>(cursor),
                   s.normal_begin_n + (s.normal_end_n - s.normal_begin_n) * fraction,
                   s.lateral_begin_m + (s.lateral_end_m - s.lateral_begin_m) * fraction,
                   s.ticks_per_sample};
}

}  // namespace tribo::daemon
