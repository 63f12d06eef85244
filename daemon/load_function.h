// A validated protocol compiled into tick ranges: the setpoints of every tick
// are a cheap function of the tick number, with no allocation in the loop.
// SI units; ticks of the nominal loop period.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tribo/v1/protocol.pb.h"

namespace tribo::daemon {

struct SegmentPlan {
  std::string name;
  std::uint64_t start_tick = 0;
  std::uint64_t tick_count = 0;
  double normal_begin_n = 0, normal_end_n = 0;
  double lateral_begin_m = 0, lateral_end_m = 0;
  std::uint32_t ticks_per_sample = 1;  // loop rate / acquisition rate
};

struct Setpoints {
  std::uint32_t segment = 0;
  double normal_force_n = 0;
  double lateral_position_m = 0;
  std::uint32_t ticks_per_sample = 1;
};

class LoadFunction {
 public:
  LoadFunction() = default;
  LoadFunction(std::vector<SegmentPlan> segments, double loop_rate_hz);

  std::uint64_t total_ticks() const { return total_ticks_; }
  double loop_rate_hz() const { return loop_rate_hz_; }
  const std::vector<SegmentPlan>& segments() const { return segments_; }
  std::uint64_t expected_samples() const;

  // Setpoints at tick (< total_ticks). cursor is the caller's segment index,
  // advanced monotonically so a run costs O(1) per tick; start it at 0.
  Setpoints at(std::uint64_t tick, std::size_t& cursor) const;

 private:
  std::vector<SegmentPlan> segments_;
  std::uint64_t total_ticks_ = 0;
  double loop_rate_hz_ = 0;
};

}  // namespace tribo::daemon
