#include "analysis/scratch_metrics.h"

#include <cmath>

#include "analysis/segment_spans.h"

namespace tribo::analysis {

namespace {

bool constant_normal(const v1::SampleBlock& b, const SegmentSpan& s) {
  return std::fabs(b.normal_setpoint_n(s.last) - b.normal_setpoint_n(s.first)) <= 1e-12;
}

// Least-squares line y = a + b x; returns false when x does not vary.
bool line_fit(const std::vector<double>& x, const std::vector<double>& y, double& a, double& b, double& b_se) {
  const double n = static_cast<double>(x.size());
  if (x.size() < 3) return false;
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (!(sxx > 0)) return false;
  b = sxy / sxx;
  a = my - b * mx;
  double sse = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sse += (y[i] - a - b * x[i]) * (y[i] - a - b * x[i]);
  b_se = std::sqrt(sse / (n - 2) / sxx);
  return true;
}

}  // namespace

std::optional<TiltFit> fit_surface_tilt(const v1::SampleBlock& b) {
  for (const SegmentSpan& s : segment_spans(b)) {
    if (s.last - s.first < 3 || !constant_normal(b, s) || !lateral_setpoint_moves(b, s)) continue;
    std::vector<double> x, z;
    for (int i = s.first; i <= s.last; ++i) {
      x.push_back(b.lateral_position_m(i));
      z.push_back(b.normal_displacement_m(i));
    }
    TiltFit fit;
    double se = 0;
    if (!line_fit(x, z, fit.intercept_m, fit.slope, se)) continue;
    fit.segment = b.segment_index(s.first);
    fit.samples = x.size();
    return fit;
  }
  return std::nullopt;
}

std::vector<double> tilt_corrected_depth(const v1::SampleBlock& b, const TiltFit& tilt) {
  std::vector<double> depth(static_cast<std::size_t>(b.time_s_size()));
  for (int i = 0; i < b.time_s_size(); ++i) {
    depth[static_cast<std::size_t>(i)] = b.normal_displacement_m(i) - (tilt.intercept_m + tilt.slope * b.lateral_position_m(i));
  }
  return depth;
}

DriftFromHolds lateral_drift_from_holds(const v1::SampleBlock& b) {
  DriftFromHolds out;
  double weighted = 0, total = 0;
  for (const SegmentSpan& s : segment_spans(b)) {
    if (s.last - s.first < 3 || lateral_setpoint_moves(b, s) || !constant_normal(b, s) || !(b.normal_setpoint_n(s.first) > 0)) continue;
    std::vector<double> t, f;
    for (int i = s.first; i <= s.last; ++i) {
      t.push_back(b.time_s(i));
      f.push_back(b.lateral_force_n(i));
    }
    HoldDrift h;
    double a = 0;
    if (!line_fit(t, f, a, h.rate_n_per_s, h.rate_std_error)) continue;
    h.segment = b.segment_index(s.first);
    h.duration_s = t.back() - t.front();
    weighted += h.rate_n_per_s * h.duration_s;
    total += h.duration_s;
    out.holds.push_back(h);
  }
  out.mean_rate_n_per_s = total > 0 ? weighted / total : 0.0;
  return out;
}

Table51Gains table51_gains(double fs, double ts, double ds, double dl, double v0) {
  Table51Gains g;
  const double speed = std::fabs(v0);
  g.contact_stiffness_n_per_m = ds > 0 ? fs / ds : 0.0;
  g.integral_gain = speed > 0 && ts > 0 ? 2 * fs / (speed * ts * ts) : 0.0;
  g.proportional_gain = speed > 0 ? g.integral_gain * dl / speed : 0.0;
  return g;
}

std::vector<ScratchIdentification> scratch_identification(const v1::SampleBlock& b) {
  std::vector<ScratchIdentification> out;
  for (const SlidingSegmentMetrics& m : sliding_segment_metrics(b)) {
    ScratchIdentification id;
    id.metrics = m;
    id.stretch_time_s = m.stiction_time_s;
    int first = -1, peak = -1;
    for (int i = 0; i < b.time_s_size(); ++i) {
      if (b.segment_index(i) != m.segment || (b.status_flags(i) & v1::SAFE_UNLOAD)) continue;
      if (first < 0) first = i;
      if (b.time_s(i) <= m.begin_s + m.stiction_time_s) peak = i;
    }
    if (first >= 0 && peak >= 0) id.stretch_distance_m = std::fabs(b.lateral_position_m(peak) - b.lateral_position_m(first));
    id.gains = table51_gains(m.stiction_peak_n, id.stretch_time_s, id.stretch_distance_m, m.steady_lag_m, m.velocity_m_per_s);
    out.push_back(id);
  }
  return out;
}

}  // namespace tribo::analysis
