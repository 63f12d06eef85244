#include "scorecard/transition_metrics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace tribo::scorecard {

namespace {

double mean(const std::vector<double>& v, std::size_t from, std::size_t to) {
  return std::accumulate(v.begin() + static_cast<long>(from), v.begin() + static_cast<long>(to), 0.0) /
         static_cast<double>(to - from);
}

// Centred moving average over `half` samples each side.
std::vector<double> smooth(const std::vector<double>& v, std::size_t half) {
  std::vector<double> out(v.size());
  double sum = 0;
  std::size_t lo = 0, hi = 0;  // window [lo, hi)
  for (std::size_t k = 0; k < v.size(); ++k) {
    const std::size_t want_lo = k >= half ? k - half : 0, want_hi = std::min(v.size(), k + half + 1);
    while (hi < want_hi) sum += v[hi++];
    while (lo < want_lo) sum -= v[lo++];
    out[k] = sum / static_cast<double>(hi - lo);
  }
  return out;
}

// The noise of the velocity a 1 kHz record (means of 1 ms of ticks) gives
// by central differences, from the ticks [from, end): its RMS about its own
// 21 ms moving average, so that the motion (the tip still settling after
// break-away) is not counted as noise.
double record_velocity_noise(const std::vector<double>& position, double dt, std::size_t from) {
  const std::size_t per = static_cast<std::size_t>(std::max<long>(1, std::lround(1e-3 / dt)));
  std::vector<double> record;
  for (std::size_t k = from; k + per <= position.size(); k += per) record.push_back(mean(position, k, k + per));
  if (record.size() < 3) return 0;
  std::vector<double> v;
  for (std::size_t k = 1; k + 1 < record.size(); ++k) {
    v.push_back((record[k + 1] - record[k - 1]) / (2 * static_cast<double>(per) * dt));
  }
  const std::vector<double> trend = smooth(v, 10);
  double ss = 0;
  for (std::size_t k = 0; k < v.size(); ++k) ss += (v[k] - trend[k]) * (v[k] - trend[k]);
  return std::sqrt(ss / static_cast<double>(v.size()));
}

}  // namespace

double dissertation_record_interval_s(double velocity_m_per_s) {
  constexpr double kLoadFunctionS = 16.0, kScratchM = 16e-6, kPoints = 5000;
  return (kLoadFunctionS + kScratchM / velocity_m_per_s) / kPoints;
}

RecordedMotion motion_as_recorded(const std::vector<double>& position, double position_before, double dt,
                                  double interval_s) {
  const auto per = static_cast<std::size_t>(std::max<long>(1, std::lround(interval_s / dt)));
  const double h = static_cast<double>(per) * dt;
  std::vector<double> record{position_before};
  for (std::size_t k = 0; k + per <= position.size(); k += per) record.push_back(mean(position, k, k + per));
  RecordedMotion m;
  std::vector<double> acceleration;
  double v_prev = 0;  // at rest before the onset
  for (std::size_t k = 1; k < record.size(); ++k) {
    const double v = (record[k] - record[k - 1]) / h;
    m.peak_velocity_m_per_s = std::max(m.peak_velocity_m_per_s, v);
    acceleration.push_back((v - v_prev) / h);
    v_prev = v;
  }
  for (std::size_t k = 0; k < acceleration.size(); ++k) {
    m.peak_acceleration_m_per_s2 = std::max(m.peak_acceleration_m_per_s2, acceleration[k]);
    if (k >= 3) {
      m.peak_acceleration_ma4_m_per_s2 = std::max(m.peak_acceleration_ma4_m_per_s2, mean(acceleration, k - 3, k + 1));
    }
  }
  return m;
}

Breakaway measure_transition(const TransitionRecord& r) {
  const std::size_t ticks = r.force_n.size();
  const double dt = r.dt_s;
  // 5 ms windows: the force averaged as a record with a few points per
  // feature would be.
  const std::size_t half = static_cast<std::size_t>(std::lround(0.0025 / dt));
  const std::vector<double> f = smooth(r.force_n, half);
  Breakaway b;
  b.steady_n = mean(r.force_n, ticks * 7 / 10, ticks);
  double lag = 0;
  for (std::size_t k = ticks * 8 / 10; k < ticks; ++k) lag += r.setpoint_m[k] - r.position_m[k];
  b.lag_m = lag / static_cast<double>(ticks - ticks * 8 / 10);
  // A spike: the force falls by 2 % of its running maximum, and by at least
  // four times the force noise left in the 5 ms average (at light loads 2 %
  // is within the noise).
  const double noise = r.force_noise_n / std::sqrt(static_cast<double>(2 * half + 1));
  std::size_t peak = 0;
  bool found = false;
  for (std::size_t k = 0; k < ticks; ++k) {
    if (f[k] > f[peak]) peak = k;
    if (f[peak] > 0 && f[k] < f[peak] - std::max(0.02 * f[peak], 4 * noise) && f[peak] > 0.5 * b.steady_n) {
      found = true;
      break;
    }
  }
  if (!found) {  // no spike: the end of the rise, 99 % of the steady friction
    peak = 0;
    while (peak + 1 < ticks && f[peak] < 0.99 * b.steady_n) ++peak;
  }
  b.spike = found;
  b.peak_n = f[peak];
  b.rise_n = f[peak] - r.force_before_n;
  b.time_to_peak_s = static_cast<double>(peak + 1) * dt;
  b.stretch_m =
      mean(r.position_m, peak > half ? peak - half : 0, std::min(ticks, peak + half + 1)) - r.position_before_m;

  const double interval = dissertation_record_interval_s(r.velocity_m_per_s);
  const RecordedMotion recorded = motion_as_recorded(r.position_m, r.position_before_m, dt, interval);
  b.overshoot = recorded.peak_velocity_m_per_s / r.velocity_m_per_s;
  b.peak_acceleration_m_per_s2 = recorded.peak_acceleration_m_per_s2;
  b.peak_acceleration_ma4_m_per_s2 = recorded.peak_acceleration_ma4_m_per_s2;
  if (!r.tip_position_m.empty()) {
    const RecordedMotion tip = motion_as_recorded(r.tip_position_m, r.tip_position_before_m, dt, interval);
    b.tip_overshoot = tip.peak_velocity_m_per_s / r.velocity_m_per_s;
    b.tip_peak_acceleration_m_per_s2 = tip.peak_acceleration_m_per_s2;
  }
  b.velocity_noise_m_per_s = record_velocity_noise(r.position_m, dt, ticks / 2);
  return b;
}

}  // namespace tribo::scorecard
