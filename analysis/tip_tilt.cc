#include "analysis/tip_tilt.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "analysis/segment_spans.h"

namespace tribo::analysis {

namespace {

constexpr double kFullContactFraction = 0.5;
constexpr double kHeldLoadFraction = 1e-6;  // a normal setpoint constant to this is a hold

double peak_normal_setpoint_n(const v1::SampleBlock& b, const SegmentSpan& s) {
  double peak = 0;
  for (int i = s.first; i <= s.last; ++i) peak = std::max(peak, b.normal_setpoint_n(i));
  return peak;
}

bool normal_holds(const v1::SampleBlock& b, const SegmentSpan& s) {
  double lo = b.normal_setpoint_n(s.first), hi = lo;
  for (int i = s.first; i <= s.last; ++i) {
    lo = std::min(lo, b.normal_setpoint_n(i));
    hi = std::max(hi, b.normal_setpoint_n(i));
  }
  return hi - lo <= kHeldLoadFraction * hi;
}

}  // namespace

void TipTiltAccumulator::add(const v1::SampleBlock& b, int first, int last) {
  const SegmentSpan s{first, last};
  const double peak_n = peak_normal_setpoint_n(b, s);
  if (lateral_setpoint_moves(b, s)) {
    if (peak_n > 0) slid_under_load_ = true;
  } else if (peak_n > 0 && !slid_under_load_ && normal_holds(b, s) && s.last - s.first >= 3) {
    std::uint64_t used = 0;
    for (int i = s.first; i <= s.last; ++i) {
      if (b.normal_force_n(i) < kFullContactFraction * peak_n) continue;
      lateral_ += b.lateral_force_n(i);
      normal_ += b.normal_force_n(i);
      ++used;
    }
    if (used > 0) {
      if (e_.holds++ == 0) e_.first_segment = b.segment_index(s.first);
      e_.samples += used;
    }
  }
  if (!(b.normal_setpoint_n(s.last) > 0)) slid_under_load_ = false;  // unloaded: the bristles relax
}

std::optional<TipTiltEstimate> TipTiltAccumulator::estimate() const {
  if (e_.samples == 0 || !(normal_ > 0)) return std::nullopt;
  TipTiltEstimate e = e_;
  e.tan_tilt = -lateral_ / normal_;
  e.mean_normal_force_n = normal_ / static_cast<double>(e.samples);
  e.mean_lateral_force_n = lateral_ / static_cast<double>(e.samples);
  return e;
}

std::optional<TipTiltEstimate> estimate_tip_tilt(const v1::SampleBlock& b) {
  TipTiltAccumulator tilt;
  for (const SegmentSpan& s : segment_spans(b)) tilt.add(b, s.first, s.last);
  return tilt.estimate();
}

double tilt_corrected_friction_n(double mean_friction_n, double velocity_m_per_s, double normal_force_n,
                                 double tan_tilt) {
  const double sign = velocity_m_per_s > 0 ? 1.0 : -1.0;
  return mean_friction_n + sign * normal_force_n * tan_tilt;
}

}  // namespace tribo::analysis
