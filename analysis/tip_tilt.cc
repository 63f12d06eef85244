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

std::optional<TipTiltEstimate> estimate_tip_tilt(const v1::SampleBlock& b) {
  TipTiltEstimate e;
  double lateral = 0, normal = 0;
  bool slid_under_load = false;  // since the tip was last unloaded
  for (const SegmentSpan& s : segment_spans(b)) {
    const double peak_n = peak_normal_setpoint_n(b, s);
    if (lateral_setpoint_moves(b, s)) {
      if (peak_n > 0) slid_under_load = true;
    } else if (peak_n > 0 && !slid_under_load && normal_holds(b, s) && s.last - s.first >= 3) {
      std::uint64_t used = 0;
      for (int i = s.first; i <= s.last; ++i) {
        if (b.normal_force_n(i) < kFullContactFraction * peak_n) continue;
        lateral += b.lateral_force_n(i);
        normal += b.normal_force_n(i);
        ++used;
      }
      if (used > 0) {
        if (e.holds++ == 0) e.first_segment = b.segment_index(s.first);
        e.samples += used;
      }
    }
    if (!(b.normal_setpoint_n(s.last) > 0)) slid_under_load = false;  // unloaded: the bristles relax
  }
  if (e.samples == 0 || !(normal > 0)) return std::nullopt;
  e.tan_tilt = -lateral / normal;
  e.mean_normal_force_n = normal / static_cast<double>(e.samples);
  e.mean_lateral_force_n = lateral / static_cast<double>(e.samples);
  return e;
}

double tilt_corrected_friction_n(double mean_friction_n, double velocity_m_per_s, double normal_force_n,
                                 double tan_tilt) {
  const double sign = velocity_m_per_s > 0 ? 1.0 : -1.0;
  return mean_friction_n + sign * normal_force_n * tan_tilt;
}

}  // namespace tribo::analysis
