#include "analysis/metrics/run_metrics.h"

#include <algorithm>
#include <cmath>

#include "analysis/metrics/segment_spans.h"

namespace tribo::analysis {

namespace {

// The stiction peak is taken on a centred moving average of this length, so
// that it is the spike and not the largest noise excursion among thousands of
// samples (at 10 µN force noise a 20 ms window at 1 kHz leaves ~0.7 µN).
constexpr double kPeakSmoothingS = 0.02;

bool is_loaded_sliding(const v1::SampleBlock& b, const SegmentSpan& s) {
  if (s.last - s.first < 3) return false;
  for (int i = s.first; i <= s.last; ++i) {
    if (!(b.normal_setpoint_n(i) > 0)) return false;
  }
  return lateral_setpoint_moves(b, s);
}

SlidingSegmentMetrics measure(const v1::SampleBlock& b, const SegmentSpan& s) {
  SlidingSegmentMetrics m;
  m.segment = b.segment_index(s.first);
  m.begin_s = b.time_s(s.first);
  m.end_s = b.time_s(s.last);
  m.velocity_m_per_s = (b.lateral_setpoint_m(s.last) - b.lateral_setpoint_m(s.first)) / (m.end_s - m.begin_s);
  const double sign = m.velocity_m_per_s > 0 ? 1.0 : -1.0;
  m.steady_begin_s = 0.5 * (m.begin_s + m.end_s);

  const double dt = (m.end_s - m.begin_s) / (s.last - s.first);
  const int half_window = std::max(0, static_cast<int>(std::lround(kPeakSmoothingS / dt / 2)));
  m.stiction_peak_n = -HUGE_VAL;
  for (int i = s.first; i <= s.last && b.time_s(i) < m.steady_begin_s; ++i) {
    const int lo = std::max(s.first, i - half_window), hi = std::min(s.last, i + half_window);
    double smoothed = 0;
    for (int j = lo; j <= hi; ++j) smoothed += sign * b.lateral_force_n(j);
    smoothed /= (hi - lo + 1);
    if (smoothed > m.stiction_peak_n) {
      m.stiction_peak_n = smoothed;
      m.stiction_time_s = b.time_s(i) - m.begin_s;
    }
  }

  double sum = 0, sum_sq = 0, normal = 0, lag = 0;
  for (int i = s.first; i <= s.last; ++i) {
    if (b.time_s(i) < m.steady_begin_s) continue;
    const double friction = sign * b.lateral_force_n(i);
    ++m.steady_samples;
    sum += friction;
    sum_sq += friction * friction;
    normal += b.normal_force_n(i);
    lag += sign * (b.lateral_setpoint_m(i) - b.lateral_position_m(i));
  }
  const double n = static_cast<double>(m.steady_samples);
  m.mean_friction_n = sum / n;
  m.friction_sd_n = n > 1 ? std::sqrt(std::max(0.0, (sum_sq - sum * sum / n) / (n - 1))) : 0.0;
  m.normal_force_n = normal / n;
  m.mu = m.mean_friction_n / m.normal_force_n;
  m.steady_lag_m = lag / n;
  return m;
}

}  // namespace

std::vector<SlidingSegmentMetrics> sliding_segment_metrics(const v1::SampleBlock& samples) {
  std::vector<SlidingSegmentMetrics> metrics;
  for (const SegmentSpan& span : segment_spans(samples)) {
    if (is_loaded_sliding(samples, span)) metrics.push_back(measure(samples, span));
  }
  return metrics;
}

}  // namespace tribo::analysis
