#include "analysis/effects/residual_structure.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "analysis/report/message_format.h"

namespace tribo::analysis {

namespace {

// Distance slid since the speed last changed by more than 50 % within a pass.
std::vector<double> distance_since_speed_change(const MeasuredSeries& s, const MotionSegmentation& m) {
  std::vector<double> out(s.size(), 0.0);
  for (const Pass& p : m.passes) {
    double ref = -1, anchor = s.position_m[p.first];
    for (std::size_t i = p.first; i <= p.last; ++i) {
      const double speed = std::fabs(s.velocity_m_per_s[i]);
      if (ref < 0 && m.distance_since_start_m[i] > 0) ref = speed;
      if (ref > 0 && (speed > 1.5 * ref || speed < ref / 1.5)) {
        ref = speed;
        anchor = s.position_m[i];
      }
      out[i] = std::fabs(s.position_m[i] - anchor);
    }
  }
  return out;
}

// Correlation ratio: share of the variance of y explained by equal-count bins of x.
double correlation_ratio(const std::vector<double>& x, const std::vector<double>& y, int bins, double& where_x, double& peak) {
  std::vector<std::size_t> order(x.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return x[a] < x[b]; });
  double total_mean = 0;
  for (double v : y) total_mean += v;
  total_mean /= static_cast<double>(y.size());
  double tss = 0;
  for (double v : y) tss += (v - total_mean) * (v - total_mean);
  const std::size_t per = std::max<std::size_t>(1, order.size() / static_cast<std::size_t>(bins));
  double between = 0;
  peak = 0;
  where_x = 0;
  for (std::size_t start = 0; start < order.size(); start += per) {
    const std::size_t end = std::min(order.size(), start + per);
    double sy = 0, sx = 0;
    for (std::size_t k = start; k < end; ++k) {
      sy += y[order[k]];
      sx += x[order[k]];
    }
    const double c = static_cast<double>(end - start), mean = sy / c;
    between += c * (mean - total_mean) * (mean - total_mean);
    if (std::fabs(mean) > std::fabs(peak)) {
      peak = mean;
      where_x = sx / c;
    }
  }
  return tss > 0 ? between / tss : 0.0;
}

}  // namespace

std::optional<std::string> describe_residual_structure(const ModelData& data, const std::vector<double>& residual,
                                                       const std::vector<char>& compared, double noise) {
  const MeasuredSeries& s = data.series;
  const MotionSegmentation& m = data.motion;
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < residual.size(); ++i) {
    if (!compared[i]) continue;
    sum += residual[i] * residual[i];
    ++count;
  }
  if (count == 0) return std::nullopt;
  const double rms = std::sqrt(sum / static_cast<double>(count));
  if (rms < 1.5 * noise) return std::nullopt;

  // Each regressor is read where it is (only the distance since a speed
  // change is computed), and one regressor's compared rows are gathered at a
  // time into arrays sized once: copies of all seven took 56 bytes a sample
  // at the diagnosis' end, where its memory peaks.
  struct Candidate {
    std::string name;
    std::function<double(std::size_t)> x;
    bool signed_by_direction;
  };
  const std::vector<double> since_speed_change = distance_since_speed_change(s, m);
  const auto values = [](const std::vector<double>& v) { return [&v](std::size_t i) { return v[i]; }; };
  std::vector<Candidate> regressors = {
      {"distance since the pass began (reversal or onset), m", values(m.distance_since_start_m), true},
      {"distance since the last speed change, m", values(since_speed_change), true},
      {"time, s", values(s.time_s), false},
      {"position, m", values(s.position_m), false},
      {"speed, m/s", [&s](std::size_t i) { return std::fabs(s.velocity_m_per_s[i]); }, true},
      {"acceleration, m/s^2", values(s.acceleration_m_per_s2), false},
  };
  if (s.has_normal()) regressors.push_back({"normal load", values(s.normal_force_n), false});
  double best_eta = 0, best_where = 0, best_peak = 0;
  std::string best;
  std::vector<double> x, y;
  x.reserve(count);
  y.reserve(count);
  for (const auto& c : regressors) {
    x.clear();
    y.clear();
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (!compared[i]) continue;
      x.push_back(c.x(i));
      y.push_back(c.signed_by_direction && m.direction[i] != 0 ? m.direction[i] * residual[i] : residual[i]);
    }
    double where = 0, peak = 0;
    const double eta = correlation_ratio(x, y, 40, where, peak);
    if (eta > best_eta) {
      best_eta = eta;
      best = c.name;
      best_where = where;
      best_peak = peak;
    }
  }
  std::string text = fmt("residual RMS %.4g is %.1f x the white-noise floor (%.3g); ", rms, rms / std::max(noise, 1e-300), noise);
  text += "its structure follows the " + best + fmt(" most closely (binned means explain %.0f %% of its variance; largest mean %.3g near %.4g)",
                                                    100 * best_eta, best_peak, best_where);
  return text;
}

}  // namespace tribo::analysis
