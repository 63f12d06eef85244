#include "analysis/metrics/tip_tilt.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "analysis/metrics/segment_spans.h"

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

std::optional<PassesTiltEstimate> estimate_tilt_from_passes(const std::vector<PassFriction>& passes) {
  constexpr double kSameSpeed = 0.01, kSameLoad = 0.05;
  std::vector<bool> taken(passes.size(), false);
  double weighted = 0;
  PassesTiltEstimate e;
  for (std::size_t i = 0; i < passes.size(); ++i) {
    if (taken[i] || !(passes[i].normal_force_n > 0)) continue;
    const double speed = std::fabs(passes[i].velocity_m_per_s), load = passes[i].normal_force_n;
    double mu_sum[2] = {0, 0};  // [0] +x, [1] -x
    std::uint32_t count[2] = {0, 0};
    for (std::size_t j = i; j < passes.size(); ++j) {
      const PassFriction& p = passes[j];
      if (taken[j] || !(p.normal_force_n > 0) || p.velocity_m_per_s == 0) continue;
      if (std::fabs(std::fabs(p.velocity_m_per_s) - speed) > kSameSpeed * speed) continue;
      if (std::fabs(p.normal_force_n - load) > kSameLoad * load) continue;
      taken[j] = true;
      const int side = p.velocity_m_per_s > 0 ? 0 : 1;
      mu_sum[side] += p.mean_friction_n / p.normal_force_n;
      ++count[side];
    }
    if (count[0] == 0 || count[1] == 0) continue;
    const double tan_tilt = (mu_sum[1] / count[1] - mu_sum[0] / count[0]) / 2;
    weighted += tan_tilt * (count[0] + count[1]);
    e.forward_passes += count[0];
    e.backward_passes += count[1];
  }
  if (e.forward_passes == 0) return std::nullopt;
  e.tan_tilt = weighted / (e.forward_passes + e.backward_passes);
  return e;
}

bool hold_tilt_agrees(double hold_tan_tilt, double passes_tan_tilt) {
  return std::fabs(hold_tan_tilt - passes_tan_tilt) <= kHoldTiltAgreement;
}

double tilt_corrected_friction_n(double mean_friction_n, double velocity_m_per_s, double normal_force_n,
                                 double tan_tilt) {
  const double sign = velocity_m_per_s > 0 ? 1.0 : -1.0;
  return mean_friction_n + sign * normal_force_n * tan_tilt;
}

}  // namespace tribo::analysis
