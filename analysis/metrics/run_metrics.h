// Metrics of a recorded run that every friction experiment reports: for each
// loaded sliding segment, the mean friction and mu over the steady part, the
// stiction peak, and the steady lag of the measured behind the commanded
// position. Works from the samples alone (SI units): a segment is "loaded
// sliding" when its normal setpoint stays above zero and its lateral setpoint
// moves; samples taken while unloading after a stop are left out.
#pragma once

#include <cstdint>
#include <vector>

#include "tribo/v1/api.pb.h"

namespace tribo::analysis {

struct SlidingSegmentMetrics {
  std::uint32_t segment = 0;
  double begin_s = 0, end_s = 0;           // first and last sample of the segment
  double velocity_m_per_s = 0;             // commanded, signed
  double steady_begin_s = 0;               // steady window: the second half of the segment
  std::uint64_t steady_samples = 0;
  double mean_friction_n = 0;              // lateral force * sgn(v) averaged over the window
  double friction_sd_n = 0;
  double normal_force_n = 0;               // mean measured normal force over the window
  double mu = 0;
  double stiction_peak_n = 0;              // max of the 20 ms moving average, first half
  double stiction_time_s = 0;              // from begin_s
  double steady_lag_m = 0;                 // mean (setpoint - position) * sgn(v) over the window
};

std::vector<SlidingSegmentMetrics> sliding_segment_metrics(const v1::SampleBlock& samples);

}  // namespace tribo::analysis
