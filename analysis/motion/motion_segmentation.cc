#include "analysis/motion/motion_segmentation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

namespace tribo::analysis {

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Smoothed velocity: a centred moving average over window_s.
std::vector<double> smoothed_velocity(const MeasuredSeries& s, double window_s) {
  const std::size_t n = s.size();
  std::vector<double> out(n);
  std::size_t lo = 0, hi = 0;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (hi < n && s.time_s[hi] <= s.time_s[i] + 0.5 * window_s) sum += s.velocity_m_per_s[hi++];
    while (s.time_s[lo] < s.time_s[i] - 0.5 * window_s) sum -= s.velocity_m_per_s[lo++];
    out[i] = sum / static_cast<double>(hi - lo);
  }
  return out;
}

// Holds: runs where the smoothed speed stays below the threshold long enough.
std::vector<Hold> find_holds(const MeasuredSeries& s, const std::vector<double>& smoothed, double threshold,
                             double min_hold_s) {
  const std::size_t n = s.size();
  std::vector<Hold> holds;
  std::size_t i = 0;
  while (i < n) {
    if (std::fabs(smoothed[i]) >= threshold) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < n && std::fabs(smoothed[j + 1]) < threshold) ++j;
    if (s.time_s[j] - s.time_s[i] >= min_hold_s) holds.push_back({i, j});
    i = j + 1;
  }
  return holds;
}

// Splits the motion run [first, last] into passes by position hysteresis.
// A reversal needs both: the position back from its extreme by delta, and
// the smoothed velocity pointing the other way (noise alone does neither).
void split_run(const MeasuredSeries& s, const std::vector<double>& smoothed, std::size_t first, std::size_t last,
               double delta, std::vector<Pass>& passes) {
  const auto& x = s.position_m;
  std::size_t start = first;
  int dir = 0;
  std::size_t hi = first, lo = first;  // running extremes since start
  for (std::size_t i = first; i <= last; ++i) {
    if (x[i] > x[hi]) hi = i;
    if (x[i] < x[lo]) lo = i;
    if (dir == 0) {
      if (x[hi] - x[lo] > delta) dir = hi > lo ? +1 : -1;
      continue;
    }
    const std::size_t ext = dir > 0 ? hi : lo;
    if (dir * (x[ext] - x[i]) > delta && dir * smoothed[i] < 0) {
      Pass p;
      p.first = start;
      p.last = ext;
      p.direction = dir;
      passes.push_back(p);
      start = ext + 1 <= i ? ext + 1 : i;
      dir = -dir;
      hi = lo = start;
      for (std::size_t k = start; k <= i; ++k) {
        if (x[k] > x[hi]) hi = k;
        if (x[k] < x[lo]) lo = k;
      }
    }
  }
  if (dir == 0) {
    // Never moved by more than the reversal distance: the direction of the mean velocity.
    double mean_v = 0;
    for (std::size_t i = first; i <= last; ++i) mean_v += s.velocity_m_per_s[i];
    dir = mean_v >= 0 ? +1 : -1;
  }
  Pass p;
  p.first = start;
  p.last = last;
  p.direction = dir;
  passes.push_back(p);
}

// Holds and passes from the setpoint (SegmentationOptions::segment_by_reference):
// a hold where it stands still for min_hold_s, a new pass after every hold and
// wherever it turns. Short standstills inside motion keep the pass's direction.
void segment_by_reference(const MeasuredSeries& s, double min_hold_s, std::vector<Hold>& holds,
                          std::vector<Pass>& passes) {
  const std::size_t n = s.size();
  const auto& r = s.reference_m;
  // Setpoint direction of sample i: its step to the next sample (the last: its step from the previous).
  std::vector<int> step(n, 0);
  double max_step = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) max_step = std::max(max_step, std::fabs(r[i + 1] - r[i]));
  const double still = 1e-6 * max_step;  // rounding of a constant setpoint
  for (std::size_t i = 0; i < n; ++i) {
    const double d = i + 1 < n ? r[i + 1] - r[i] : (n > 1 ? r[i] - r[i - 1] : 0.0);
    step[i] = d > still ? +1 : (d < -still ? -1 : 0);
  }
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j + 1 < n && (step[j + 1] == 0) == (step[i] == 0)) ++j;
    if (step[i] == 0 && s.time_s[j] - s.time_s[i] >= min_hold_s) holds.push_back({i, j});
    i = j + 1;
  }
  auto add_passes = [&](std::size_t first, std::size_t end_exclusive) {
    int dir = 0;
    for (std::size_t i = first; i < end_exclusive; ++i) {
      if (step[i] == 0 || step[i] == dir) continue;
      if (dir != 0) passes.back().last = i - 1;
      passes.push_back({});
      passes.back().first = dir != 0 ? i : first;
      passes.back().direction = dir = step[i];
    }
    if (dir != 0) passes.back().last = end_exclusive - 1;
  };
  std::size_t cursor = 0;
  for (const Hold& h : holds) {
    add_passes(cursor, h.first);
    cursor = h.last + 1;
  }
  add_passes(cursor, n);
}

// Groups sorted values into levels: a new level when the next value exceeds
// the level's first value by more than the ratio (values > 0).
std::vector<int> cluster_levels(const std::vector<double>& values, double ratio, std::vector<double>& level_values) {
  std::vector<std::size_t> order(values.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return values[a] < values[b]; });
  std::vector<int> level(values.size(), 0);
  level_values.clear();
  double level_start = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const double v = values[order[k]];
    if (level_values.empty() || v > level_start * ratio + 1e-300) {
      level_start = v;
      level_values.push_back(v);
    }
    level[order[k]] = static_cast<int>(level_values.size()) - 1;
  }
  return level;
}

}  // namespace

double white_noise_rms(const std::vector<double>& y) {
  if (y.size() < 5) return 0.0;
  std::vector<double> d2(y.size() - 2);
  for (std::size_t i = 1; i + 1 < y.size(); ++i) d2[i - 1] = y[i + 1] - 2 * y[i] + y[i - 1];
  const double med = percentile(d2, 0.5);
  for (double& d : d2) d = std::fabs(d - med);
  return 1.4826 * percentile(d2, 0.5) / std::sqrt(6.0);
}

MotionSegmentation segment_motion(const MeasuredSeries& s, const SegmentationOptions& options) {
  const std::size_t n = s.size();
  MotionSegmentation m;
  m.direction.assign(n, 0);
  m.pass_of.assign(n, -1);
  m.distance_since_start_m.assign(n, 0.0);
  m.heldout.assign(n, 0);
  m.block_of.assign(n, 0);
  if (n == 0) return m;

  const double duration = s.time_s.back() - s.time_s.front();
  const double dt = duration / static_cast<double>(n - 1);
  std::vector<double> speed(n);
  for (std::size_t i = 0; i < n; ++i) speed[i] = std::fabs(s.velocity_m_per_s[i]);
  // Holds are found on the velocity smoothed over a quarter of the minimum
  // hold (at least 10 samples), against a threshold above the smoothed noise.
  const double min_hold = options.min_hold_s > 0 ? options.min_hold_s : std::max(0.05, 20 * dt);
  const double window = std::max(0.25 * min_hold, 10 * dt);
  m.smoothing_window_s = window;
  const std::vector<double> smoothed = smoothed_velocity(s, window);
  std::vector<double> smoothed_speed(n);
  for (std::size_t i = 0; i < n; ++i) smoothed_speed[i] = std::fabs(smoothed[i]);
  const double v95 = percentile(smoothed_speed, 0.95);
  const double smoothed_noise = white_noise_rms(s.velocity_m_per_s) / std::sqrt(std::max(window / dt, 1.0));
  // A smoother's velocity (analysis/motion/motion_estimate.h) is not white: its own
  // standard deviation, which the estimator reports, sets the floor.
  m.hold_speed_m_per_s = std::max({options.hold_speed_fraction * v95, 3.0 * smoothed_noise, 3.0 * s.velocity_noise_m_per_s});

  const auto [xmin, xmax] = std::minmax_element(s.position_m.begin(), s.position_m.end());
  m.position_noise_m = white_noise_rms(s.position_m);
  // A smoothed position (analysis/motion/motion_estimate.h) has almost no white
  // noise left; the record's own noise floor still bounds what is a reversal.
  m.reversal_distance_m =
      std::max({options.reversal_fraction * (*xmax - *xmin), 5.0 * m.position_noise_m, 5.0 * s.position_noise_m});

  // Holds, and passes in the motion runs between them.
  if (options.segment_by_reference && !s.reference_m.empty()) {
    segment_by_reference(s, min_hold, m.holds, m.passes);
  } else {
    m.holds = find_holds(s, smoothed, m.hold_speed_m_per_s, min_hold);
    std::size_t cursor = 0;
    auto motion_until = [&](std::size_t end_exclusive) {
      if (end_exclusive > cursor) split_run(s, smoothed, cursor, end_exclusive - 1, m.reversal_distance_m, m.passes);
    };
    for (const Hold& h : m.holds) {
      motion_until(h.first);
      cursor = h.last + 1;
    }
    motion_until(n);
  }

  // Per-pass attributes and per-sample labels.
  std::size_t hold_index = 0;
  for (std::size_t p = 0; p < m.passes.size(); ++p) {
    Pass& pass = m.passes[p];
    while (hold_index < m.holds.size() && m.holds[hold_index].last < pass.first) ++hold_index;
    if (hold_index > 0 && m.holds[hold_index - 1].last + 1 == pass.first) {
      const Hold& h = m.holds[hold_index - 1];
      pass.after_hold = true;
      pass.dwell_before_s = s.time_s[h.last] - s.time_s[h.first];
    }
    std::vector<double> pass_speed;
    double normal = 0;
    for (std::size_t i = pass.first; i <= pass.last; ++i) {
      m.direction[i] = pass.direction;
      m.pass_of[i] = static_cast<int>(p);
      m.distance_since_start_m[i] = std::fabs(s.position_m[i] - s.position_m[pass.first]);
      pass_speed.push_back(speed[i]);
      if (s.has_normal()) normal += s.normal_force_n[i];
    }
    pass.median_speed_m_per_s = percentile(pass_speed, 0.5);
    pass.mean_normal_n = s.has_normal() ? normal / static_cast<double>(pass.last - pass.first + 1) : 0.0;
  }

  // Condition levels: speed within a factor 1.25, load within 10 %.
  std::vector<double> speeds, loads;
  for (const Pass& p : m.passes) {
    speeds.push_back(std::max(p.median_speed_m_per_s, 1e-300));
    loads.push_back(std::max(p.mean_normal_n, 1e-300));
  }
  const auto speed_level = cluster_levels(speeds, 1.25, m.speed_levels_m_per_s);
  std::vector<double> load_values;
  const auto load_level = cluster_levels(loads, 1.10, load_values);
  if (s.has_normal()) m.load_levels_n = load_values;
  for (std::size_t p = 0; p < m.passes.size(); ++p) {
    m.passes[p].speed_level = speed_level[p];
    m.passes[p].load_level = s.has_normal() ? load_level[p] : 0;
  }

  // Held-out passes: alternate in time within each condition (direction, load
  // level, speed level), the alternation shifted by one for the other
  // direction and for every other load and speed level, so that each
  // condition is fitted somewhere and held out somewhere else, and the fit set
  // never pairs one direction with one speed only.
  std::map<std::tuple<int, int, int>, int> seen;
  int heldout_passes = 0;
  for (Pass& p : m.passes) {
    const int k = seen[{p.direction, p.load_level, p.speed_level}]++;
    p.heldout = ((k + p.load_level + p.speed_level + (p.direction < 0 ? 1 : 0)) % 2) == 1;
  }
  // The first and the last pass are always fitted: held-out error then
  // measures interpolation in time, never extrapolation of a trend in time.
  if (!m.passes.empty()) {
    m.passes.front().heldout = false;
    m.passes.back().heldout = false;
  }
  for (const Pass& p : m.passes) heldout_passes += p.heldout ? 1 : 0;
  if (heldout_passes >= options.min_heldout_passes) {
    m.heldout_scheme = "whole passes, alternating in time within each (direction, load, speed) condition, shifted between conditions; first and last pass fitted";
    m.block_count = static_cast<int>(m.passes.size());
    int next_pass = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (m.pass_of[i] >= 0) next_pass = m.pass_of[i];
      else {
        // A hold belongs with the pass that follows it (its dwell shapes that onset).
        while (next_pass + 1 < static_cast<int>(m.passes.size()) && m.passes[static_cast<std::size_t>(next_pass)].last < i) ++next_pass;
      }
      m.block_of[i] = next_pass;
      m.heldout[i] = m.passes.empty() ? 0 : m.passes[static_cast<std::size_t>(next_pass)].heldout;
    }
  } else {
    m.heldout_scheme = "too few passes: " + std::to_string(options.fallback_chunks) +
                       " contiguous time chunks, alternately fit and held out";
    m.block_count = options.fallback_chunks;
    for (Pass& p : m.passes) p.heldout = false;
    for (std::size_t i = 0; i < n; ++i) {
      const double f = (s.time_s[i] - s.time_s.front()) / std::max(duration, 1e-300);
      const int chunk = std::min(options.fallback_chunks - 1, static_cast<int>(f * options.fallback_chunks));
      m.block_of[i] = chunk;
      m.heldout[i] = chunk % 2;
    }
  }
  return m;
}

std::vector<Hold> rest_stretches(const MeasuredSeries& s, const MotionSegmentation& m, double margin_s,
                                 std::size_t min_samples) {
  std::vector<Hold> out;
  for (std::size_t first = 0; first < s.size();) {
    if (m.pass_of[first] >= 0) {
      ++first;
      continue;
    }
    std::size_t end = first;
    while (end < s.size() && m.pass_of[end] < 0) ++end;
    std::size_t a = first, b = end - 1;
    while (a <= b && s.time_s[a] - s.time_s[first] < margin_s) ++a;
    while (b > a && s.time_s[end - 1] - s.time_s[b] < margin_s) --b;
    if (a <= b && b - a + 1 >= min_samples) out.push_back({a, b});
    first = end;
  }
  return out;
}

bool slides_both_ways(const MotionSegmentation& m) {
  const auto positive = [](const Pass& p) { return p.direction > 0; };
  const auto negative = [](const Pass& p) { return p.direction < 0; };
  return std::any_of(m.passes.begin(), m.passes.end(), positive) && std::any_of(m.passes.begin(), m.passes.end(), negative);
}

bool slides_one_way(const MotionSegmentation& m) { return !m.passes.empty() && !slides_both_ways(m); }

}  // namespace tribo::analysis
