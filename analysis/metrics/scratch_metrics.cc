#include "analysis/metrics/scratch_metrics.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "analysis/metrics/segment_spans.h"

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

namespace {

// Least-squares slope of y against t.
double slope(const std::vector<double>& t, const std::vector<double>& y) {
  const double n = static_cast<double>(t.size());
  if (t.size() < 2) return 0.0;
  double st = 0, sy = 0;
  for (std::size_t i = 0; i < t.size(); ++i) st += t[i], sy += y[i];
  const double mt = st / n, my = sy / n;
  double stt = 0, sty = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    stt += (t[i] - mt) * (t[i] - mt);
    sty += (t[i] - mt) * (y[i] - my);
  }
  return stt > 0 ? sty / stt : 0.0;
}

std::string format_number(double v, int digits) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(digits) << v;
  return text.str();
}

// Samples of one segment (not of a safe unload).
std::vector<int> samples_of(const v1::SampleBlock& b, std::uint32_t segment) {
  std::vector<int> out;
  for (int i = 0; i < b.time_s_size(); ++i) {
    if (b.segment_index(i) == segment && !(b.status_flags(i) & v1::SAFE_UNLOAD)) out.push_back(i);
  }
  return out;
}

int setpoint_reversals(const v1::SampleBlock& b, const std::vector<int>& idx) {
  constexpr double kStepM = 1e-12;  // changes below this are not a direction
  int reversals = 0, direction = 0;
  for (std::size_t k = 1; k < idx.size(); ++k) {
    const double d = b.lateral_setpoint_m(idx[k]) - b.lateral_setpoint_m(idx[k - 1]);
    const int dir = d > kStepM ? 1 : d < -kStepM ? -1 : 0;
    if (dir == 0) continue;
    if (direction != 0 && dir != direction) ++reversals;
    direction = dir;
  }
  return reversals;
}

struct SineFit {
  double amplitude = 0;
  double phase_rad = 0;  // y ~ amplitude sin(w t + phase)
};

// y = c0 + c1 t + a sin(w t) + b cos(w t), by the normal equations (4x4).
SineFit fit_sine(const std::vector<double>& t, const std::vector<double>& y, double w) {
  double m[4][5] = {};
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double basis[4] = {1.0, t[i], std::sin(w * t[i]), std::cos(w * t[i])};
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) m[r][c] += basis[r] * basis[c];
      m[r][4] += basis[r] * y[i];
    }
  }
  for (int col = 0; col < 4; ++col) {  // Gauss-Jordan with partial pivoting
    int pivot = col;
    for (int r = col + 1; r < 4; ++r) {
      if (std::fabs(m[r][col]) > std::fabs(m[pivot][col])) pivot = r;
    }
    if (std::fabs(m[pivot][col]) < 1e-300) return {};
    for (int c = 0; c < 5; ++c) std::swap(m[col][c], m[pivot][c]);
    for (int r = 0; r < 4; ++r) {
      if (r == col) continue;
      const double f = m[r][col] / m[col][col];
      for (int c = col; c < 5; ++c) m[r][c] -= f * m[col][c];
    }
  }
  const double a = m[2][4] / m[2][2], bc = m[3][4] / m[3][3];
  return {std::hypot(a, bc), std::atan2(bc, a)};
}

double wrap_deg(double rad) {
  double deg = rad * 180 / M_PI;
  while (deg > 180) deg -= 360;
  while (deg <= -180) deg += 360;
  return deg;
}

}  // namespace

SlidingCheck check_sliding(const v1::SampleBlock& b, const SlidingSegmentMetrics& m) {
  SlidingCheck c;
  const std::vector<int> idx = samples_of(b, m.segment);
  if (idx.empty()) {
    c.why_not = "no samples";
    return c;
  }
  std::vector<double> t, x;
  for (int i : idx) {
    if (b.time_s(i) < m.steady_begin_s) continue;
    t.push_back(b.time_s(i));
    x.push_back(b.lateral_position_m(i));
  }
  c.measured_velocity_m_per_s = slope(t, x);
  c.commanded_travel_m = b.lateral_setpoint_m(idx.back()) - b.lateral_setpoint_m(idx.front());
  c.measured_travel_m = b.lateral_position_m(idx.back()) - b.lateral_position_m(idx.front());
  c.stiction_peak_found = m.stiction_peak_n > 0 && m.stiction_peak_n > m.mean_friction_n;
  const double v_cmd = m.velocity_m_per_s, v = c.measured_velocity_m_per_s;
  std::vector<std::string> reasons;
  if (m.steady_samples < kMinSteadySamples) {
    reasons.push_back("only " + std::to_string(m.steady_samples) + " samples in the steady window (at least " +
                      std::to_string(kMinSteadySamples) + " needed: a longer segment or a higher acquisition rate)");
  }
  if (std::fabs(v - v_cmd) > kSteadyVelocityTolerance * std::fabs(v_cmd)) {
    reasons.push_back("the tip moved at " + format_number(v * 1e6, 3) + " µm/s in the steady window, " +
                      format_number(100 * v / v_cmd, 0) + "% of the commanded " + format_number(v_cmd * 1e6, 3) +
                      " µm/s (still accelerating, stick-slip or held back: a longer segment, or check the gains)");
  }
  if (!(m.mean_friction_n > 0)) {
    reasons.push_back("the mean friction " + format_number(m.mean_friction_n * 1e6, 2) +
                      " µN is not positive: the tip did not slide against friction");
  }
  c.steady = reasons.empty();
  for (std::size_t i = 0; i < reasons.size(); ++i) c.why_not += (i ? "; " : "") + reasons[i];
  return c;
}

bool is_oscillation_segment(const v1::SampleBlock& b, std::uint32_t segment) {
  return setpoint_reversals(b, samples_of(b, segment)) >= 2;
}

std::vector<OscillationMetrics> oscillation_metrics(const v1::SampleBlock& b) {
  std::vector<OscillationMetrics> out;
  for (const SegmentSpan& span : segment_spans(b)) {
    std::vector<int> idx;
    for (int i = span.first; i <= span.last; ++i) idx.push_back(i);
    if (idx.size() < 8) continue;
    const int reversals = setpoint_reversals(b, idx);
    if (reversals < 2) continue;
    OscillationMetrics o;
    o.segment = b.segment_index(span.first);
    o.begin_s = b.time_s(span.first);
    o.end_s = b.time_s(span.last);
    o.samples = idx.size();
    // The sampled span ends one sample before the segment does.
    const double dt = (o.end_s - o.begin_s) / static_cast<double>(idx.size() - 1);
    const double duration = o.end_s - o.begin_s + dt;
    o.cycles = std::round(reversals / 2.0);
    if (reversals % 2 == 1) o.cycles = std::round((reversals + 1) / 2.0);
    o.frequency_hz = o.cycles / duration;
    const double w = 2 * M_PI * o.frequency_hz;
    std::vector<double> t, sp, x, f;
    double normal = 0;
    for (int i : idx) {
      t.push_back(b.time_s(i) - o.begin_s);
      sp.push_back(b.lateral_setpoint_m(i));
      x.push_back(b.lateral_position_m(i));
      f.push_back(b.lateral_force_n(i));
      normal += b.normal_force_n(i);
    }
    o.normal_force_n = normal / static_cast<double>(idx.size());
    const SineFit s = fit_sine(t, sp, w), p = fit_sine(t, x, w), q = fit_sine(t, f, w);
    o.setpoint_amplitude_m = s.amplitude;
    o.position_amplitude_m = p.amplitude;
    o.position_phase_deg = wrap_deg(p.phase_rad - s.phase_rad);
    o.force_amplitude_n = q.amplitude;
    o.force_phase_deg = wrap_deg(q.phase_rad - p.phase_rad);
    out.push_back(o);
  }
  return out;
}

}  // namespace tribo::analysis
