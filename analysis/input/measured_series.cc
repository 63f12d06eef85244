#include "analysis/input/measured_series.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "analysis/motion/motion_estimate.h"

namespace tribo::analysis {

namespace {

std::vector<double> moving_average(const std::vector<double>& t, const std::vector<double>& y,
                                   double window_s) {
  if (window_s <= 0 || y.size() < 3) return y;
  std::vector<double> out(y.size());
  std::size_t lo = 0, hi = 0;
  double sum = 0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    while (hi < y.size() && t[hi] <= t[i] + 0.5 * window_s) sum += y[hi++];
    while (t[lo] < t[i] - 0.5 * window_s) sum -= y[lo++];
    out[i] = sum / static_cast<double>(hi - lo);
  }
  return out;
}

std::vector<double> central_difference(const std::vector<double>& t, const std::vector<double>& y) {
  const std::size_t n = y.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  for (std::size_t i = 1; i + 1 < n; ++i) d[i] = (y[i + 1] - y[i - 1]) / (t[i + 1] - t[i - 1]);
  d[0] = (y[1] - y[0]) / (t[1] - t[0]);
  d[n - 1] = (y[n - 1] - y[n - 2]) / (t[n - 1] - t[n - 2]);
  return d;
}

template <class T>
std::vector<T> cut(const std::vector<T>& v, std::size_t first, std::size_t last) {
  if (v.empty()) return v;
  return std::vector<T>(v.begin() + static_cast<std::ptrdiff_t>(first),
                        v.begin() + static_cast<std::ptrdiff_t>(last));
}

}  // namespace

void derive_motion(MeasuredSeries& s, double smoothing_s) {
  s.position_resolution_m = resolution_of(s.position_m);
  s.position_noise_m = std::max(third_difference_noise(s.position_m), s.position_resolution_m / std::sqrt(12.0));
  if (!s.velocity_m_per_s.empty()) s.motion_estimator = "measured";
  if (s.velocity_m_per_s.empty()) {
    s.motion_estimator = smoothing_s > 0 ? "moving_average_central_difference" : "central_difference";
    s.velocity_m_per_s = central_difference(s.time_s, moving_average(s.time_s, s.position_m, smoothing_s));
    s.velocity_measured = false;
  }
  if (s.acceleration_m_per_s2.empty()) {
    s.acceleration_m_per_s2 =
        central_difference(s.time_s, moving_average(s.time_s, s.velocity_m_per_s, smoothing_s));
    s.acceleration_measured = false;
  }
}

namespace {

MotionEstimate estimate_with_reference(const MeasuredSeries& s, bool loop_force, bool velocity_jumps,
                                       const Eigen::MatrixXd* loop_normal_matrix, ReferenceMotion reference_motion) {
  // The force enters the loop model only with loop_force (no copy of it otherwise).
  static const std::vector<double> no_force;
  const std::vector<double>& loop_input = loop_force ? s.force_n : no_force;
  switch (reference_motion) {
    case ReferenceMotion::setpoint_stretches:
      return estimate_motion_by_stretches(s.time_s, s.position_m, s.reference_m);
    case ReferenceMotion::loop_model:
      break;
  }
  return estimate_motion_with_reference(s.time_s, s.position_m, s.reference_m, loop_input, velocity_jumps, s.force_n,
                                        loop_normal_matrix);
}

}  // namespace

void derive_motion_smoothed(MeasuredSeries& s, bool loop_force, bool velocity_jumps, const Eigen::MatrixXd* loop_normal_matrix,
                            ReferenceMotion reference_motion) {
  if (!s.velocity_m_per_s.empty() && !s.acceleration_m_per_s2.empty()) {
    derive_motion(s, 0);
    return;
  }
  MotionEstimate m = s.reference_m.empty()
                         ? estimate_motion(s.time_s, s.position_m, velocity_jumps, s.force_n)
                         : estimate_with_reference(s, loop_force, velocity_jumps, loop_normal_matrix, reference_motion);
  s.loop_taps = m.loop_taps;
  s.loop_variance_explained = m.loop_variance_explained;
  s.loop_force_taps = m.loop_force_taps;
  s.loop_force_response_m_per_n = m.loop_force_response_m_per_n;
  s.position_noise_m = m.position_noise_m;
  s.position_resolution_m = m.position_resolution_m;
  s.velocity_noise_m_per_s = m.velocity_std_m_per_s;
  s.velocity_jumps = static_cast<int>(m.velocity_jumps.size());
  s.velocity_jumps_force_did_not_follow = m.velocity_jumps_force_did_not_follow;
  s.motion_estimator = s.velocity_m_per_s.empty() ? m.estimator : "measured velocity, acceleration " + m.estimator;
  // The estimate's arrays are moved in, never copied (three arrays a sample).
  if (s.velocity_m_per_s.empty()) {
    s.velocity_m_per_s = std::move(m.velocity_m_per_s);
    s.velocity_measured = false;
    s.position_m = std::move(m.position_m);
  }
  if (s.acceleration_m_per_s2.empty()) {
    s.acceleration_m_per_s2 = std::move(m.acceleration_m_per_s2);
    s.acceleration_measured = false;
  }
}

void keep_motion_only(MeasuredSeries& s) {
  for (auto* column : {&s.time_s, &s.force_n, &s.normal_force_n, &s.reference_m}) std::vector<double>().swap(*column);
  std::vector<std::uint32_t>().swap(s.segment);
}

MeasuredSeries with_motion_of(const MeasuredSeries& series, const MeasuredSeries& motion) {
  MeasuredSeries out = motion;
  out.source = series.source;
  out.force_unit = series.force_unit;
  out.time_s = series.time_s;
  out.force_n = series.force_n;
  out.normal_force_n = series.normal_force_n;
  return out;
}

MeasuredSeries slice(const MeasuredSeries& s, std::size_t first, std::size_t last) {
  MeasuredSeries out;
  out.source = s.source;
  out.force_unit = s.force_unit;
  out.time_s = cut(s.time_s, first, last);
  out.position_m = cut(s.position_m, first, last);
  out.velocity_m_per_s = cut(s.velocity_m_per_s, first, last);
  out.acceleration_m_per_s2 = cut(s.acceleration_m_per_s2, first, last);
  out.force_n = cut(s.force_n, first, last);
  out.normal_force_n = cut(s.normal_force_n, first, last);
  out.reference_m = cut(s.reference_m, first, last);
  out.segment = cut(s.segment, first, last);
  out.velocity_measured = s.velocity_measured;
  out.acceleration_measured = s.acceleration_measured;
  out.motion_estimator = s.motion_estimator;
  out.position_noise_m = s.position_noise_m;
  out.position_resolution_m = s.position_resolution_m;
  out.velocity_noise_m_per_s = s.velocity_noise_m_per_s;
  out.velocity_jumps = s.velocity_jumps;
  out.velocity_jumps_force_did_not_follow = s.velocity_jumps_force_did_not_follow;
  out.loop_taps = s.loop_taps;
  out.loop_variance_explained = s.loop_variance_explained;
  out.loop_force_taps = s.loop_force_taps;
  out.loop_force_response_m_per_n = s.loop_force_response_m_per_n;
  out.motion_evidence = s.motion_evidence;
  return out;
}

std::string check_series(const MeasuredSeries& s) {
  const std::size_t n = s.size();
  if (n < 16) return "too few samples (" + std::to_string(n) + ", need at least 16)";
  auto check = [&](const std::vector<double>& v, const char* name, bool optional) -> std::string {
    if (optional && v.empty()) return {};
    if (v.size() != n) return std::string(name) + " has " + std::to_string(v.size()) + " samples, time has " + std::to_string(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(v[i])) return std::string(name) + " is not finite at row " + std::to_string(i + 1);
    }
    return {};
  };
  for (auto e : {check(s.position_m, "position", false), check(s.force_n, "force", false),
                 check(s.velocity_m_per_s, "velocity", true), check(s.acceleration_m_per_s2, "acceleration", true),
                 check(s.normal_force_n, "normal force", true), check(s.reference_m, "reference", true),
                 check(s.time_s, "time", false)}) {
    if (!e.empty()) return e;
  }
  for (std::size_t i = 1; i < n; ++i) {
    if (!(s.time_s[i] > s.time_s[i - 1])) return "time does not increase at row " + std::to_string(i + 1);
  }
  return {};
}

}  // namespace tribo::analysis
