// Turns loop ticks into recorded samples: each recorded sample is the average
// of ticks_per_sample consecutive ticks (a boxcar anti-alias filter), stamped
// with the mean time of those ticks. Segments hold whole sample periods (the
// validator checks), so a recorded sample never mixes two segments.
#pragma once

#include <cstdint>

#include "proto/sample_record.h"

namespace tribo::daemon {

class Acquisition {
 public:
  // Adds one tick; returns true and fills out when a recorded sample is complete.
  bool add(const Sample& tick, std::uint32_t ticks_per_sample, Sample& out);

  // True when no partial sample is pending.
  bool empty() const { return count_ == 0; }

 private:
  Sample sum_;
  std::uint32_t count_ = 0;
};

}  // namespace tribo::daemon
