#include "analysis/motion/motion_estimate.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "analysis/motion/gram_in_sample_order.h"

namespace tribo::analysis {

namespace {

// Samples of the friction force in the loop model: this one and the two
// before it (a channel skew of a sample, a step of the servo's response).
constexpr int kForceTaps = 3;

// The setpoint's stretches (setpoint_stretches): a slope change of more than
// 2 % of the slope plus 0.1 % of the record's steepest ends a stretch (a
// ramp's changing slope makes stretches of a sample); those of fewer than 50
// samples, too few for an intensity of their own, share one.
constexpr double kStretchSlopeChange = 0.02;
constexpr double kStretchSlopeFloor = 1e-3;
constexpr std::size_t kStretchMinForItsOwnJerk = 50;

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The median sampling step (at least 1e-12 s).
double median_step(const std::vector<double>& t) {
  std::vector<double> dts;
  for (std::size_t i = 1; i < t.size(); ++i) dts.push_back(t[i] - t[i - 1]);
  return std::max(median(dts), 1e-12);
}

void transition(double dt, double q, Mat3& F, Mat3& Q) {
  F << 1, dt, 0.5 * dt * dt, 0, 1, dt, 0, 0, 1;
  const double d2 = dt * dt, d3 = d2 * dt, d4 = d3 * dt, d5 = d4 * dt;
  Q << d5 / 20, d4 / 8, d3 / 6, d4 / 8, d3 / 3, d2 / 2, d3 / 6, d2 / 2, dt;
  Q *= q;
}

// The forward filter's log-likelihood and, with `innovations`, what the
// velocity-jump test needs: each sample's innovation, its variance and the
// filter's gain. The smoother (smooth_motion) forms the filtered states
// again, chunk by chunk, rather than hold them for the whole record.
struct FilterPass {
  double log_likelihood = 0;
  std::vector<double> innovation, innovation_var;
  std::vector<Vec3> gain;
};

// Where the velocity may jump (a speed step of the drive): at[i] lets it
// change between samples i - 1 and i by anything of the order of
// variance^0.5, on top of the white jerk.
struct VelocityJumps {
  std::vector<char> at;
  double variance = 0;
};

// The prediction's covariance from sample i - 1's filtered one.
Mat3 predicted_covariance(const Mat3& F, const Mat3& P, const Mat3& Q, const VelocityJumps& jumps, std::size_t i) {
  Mat3 before = P;
  if (!jumps.at.empty() && jumps.at[i]) before(1, 1) += jumps.variance;
  return F * before * F.transpose() + Q;
}

// The filter's state: the mean and covariance after a sample (before the
// first: the diffuse prior).
struct FilterState {
  Vec3 mean;
  Mat3 cov;
};

// Positions in units of the noise (y / r_sd), so r = 1 and every number is of
// order one; q in the same units.
FilterState prior_state(const std::vector<double>& t, const std::vector<double>& y) {
  FilterState s{Vec3(y[0], 0, 0), Mat3::Zero()};
  const double span = std::max(t.back() - t.front(), 1e-12);
  const double ybig = 1e6;  // diffuse start for velocity and acceleration (noise units)
  s.cov(0, 0) = 1;
  s.cov(1, 1) = ybig / span * ybig / span;
  s.cov(2, 2) = s.cov(1, 1) / (span * span);
  return s;
}

// The innovation of a sample, its variance and the gain it was taken with.
struct FilterUpdate {
  double innovation = 0, variance = 0;
  Vec3 gain;
};

// The covariance half of a filter step is a function of the step's dt,
// whether the velocity may jump there and the covariance before it; only the
// mean half reads the data. On uniform samples the covariance mostly settles
// to a fixed point, exactly in floating point (at 1 kHz: after 0.4 thousand
// samples for a jerk intensity of 5e8 noise units, 270 thousand for 2e-9;
// some larger intensities alternate between two covariances instead), after
// which each step would repeat the last one's covariance arithmetic: the memo
// returns its results, the same bits, and the step costs a few flops. The
// maximum-likelihood search runs the filter some forty times over the record.
struct CovarianceStep {
  bool valid = false;
  double dt = 0, q = 0;
  bool jump = false;
  Mat3 cov_before, F, cov_after;
  double variance = 0;
  Vec3 gain;
};

// Takes sample i into the state (that after sample i - 1).
FilterUpdate filter_step(const std::vector<double>& t, const std::vector<double>& y, double q, const VelocityJumps& jumps,
                         std::size_t i, FilterState& state, CovarianceStep& memo) {
  FilterUpdate u;
  if (i == 0) {
    const Mat3 Pp = state.cov;
    u.variance = Pp(0, 0) + 1.0;
    u.innovation = y[i] - state.mean(0);
    u.gain = Pp.col(0) / u.variance;
    state.mean = state.mean + u.gain * u.innovation;
    state.cov = Pp - u.gain * Pp.row(0);
    state.cov = 0.5 * (state.cov + state.cov.transpose());
    return u;
  }
  const double dt = t[i] - t[i - 1];
  const bool jump = !jumps.at.empty() && jumps.at[i];
  if (!memo.valid || memo.dt != dt || memo.q != q || memo.jump != jump || memo.cov_before != state.cov) {
    memo.valid = true;
    memo.dt = dt;
    memo.q = q;
    memo.jump = jump;
    memo.cov_before = state.cov;
    Mat3 Q;
    transition(dt, q, memo.F, Q);
    const Mat3 Pp = predicted_covariance(memo.F, state.cov, Q, jumps, i);
    memo.variance = Pp(0, 0) + 1.0;
    memo.gain = Pp.col(0) / memo.variance;
    memo.cov_after = Pp - memo.gain * Pp.row(0);
    memo.cov_after = 0.5 * (memo.cov_after + memo.cov_after.transpose());
  }
  const Vec3 mp = memo.F * state.mean;
  u.variance = memo.variance;
  u.innovation = y[i] - mp(0);
  u.gain = memo.gain;
  state.mean = mp + u.gain * u.innovation;
  state.cov = memo.cov_after;
  return u;
}

// The jerk intensity of the transition into each sample: one for the
// record, or one per stretch of the setpoint (estimate_motion_by_stretches).
struct JerkIntensity {
  double constant = 0;
  const std::vector<double>* per_sample = nullptr;
  double at(std::size_t i) const { return per_sample ? (*per_sample)[i] : constant; }
};

FilterPass kalman(const std::vector<double>& t, const std::vector<double>& y, const JerkIntensity& q, const VelocityJumps& jumps,
                  bool innovations = false) {
  const std::size_t n = y.size();
  FilterPass out;
  if (innovations) {
    out.innovation.resize(n);
    out.innovation_var.resize(n);
    out.gain.resize(n);
  }
  FilterState state = prior_state(t, y);
  CovarianceStep memo;
  double log_variance = 0, log_of = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < n; ++i) {
    const FilterUpdate u = filter_step(t, y, q.at(i), jumps, i, state, memo);
    if (u.variance != log_of) log_of = u.variance, log_variance = std::log(u.variance);
    if (i > 0) out.log_likelihood += -0.5 * (log_variance + u.innovation * u.innovation / u.variance);
    if (innovations) {
      out.innovation[i] = u.innovation;
      out.innovation_var[i] = u.variance;
      out.gain[i] = u.gain;
    }
  }
  return out;
}

// The covariance half of a smoother step, memoised as the filter's
// (CovarianceStep): a function of dt, the jump flag and the filtered
// covariance, and then of the smoothed covariance that follows, which
// settles to its own fixed point away from the record's end.
struct SmootherStep {
  bool valid = false, smoothed_valid = false;
  double dt = 0, q = 0;
  bool jump = false;
  Mat3 filtered_cov, F, predicted_cov, gain, smoothed_in, smoothed_out;

  void update(double step_dt, double step_q, const VelocityJumps& jumps, std::size_t next, const Mat3& cov) {
    const bool jump_next = !jumps.at.empty() && jumps.at[next];
    if (valid && dt == step_dt && q == step_q && jump == jump_next && filtered_cov == cov) return;
    valid = true;
    smoothed_valid = false;
    dt = step_dt;
    q = step_q;
    jump = jump_next;
    filtered_cov = cov;
    Mat3 Q;
    transition(step_dt, step_q, F, Q);
    predicted_cov = predicted_covariance(F, cov, Q, jumps, next);
    gain = cov * F.transpose() * predicted_cov.inverse();
  }

  // Ps (the next sample's smoothed covariance) becomes this sample's.
  void smoothed_covariance(const Mat3& cov, Mat3& Ps) {
    if (smoothed_valid && smoothed_in == Ps) {
      Ps = smoothed_out;
      return;
    }
    smoothed_in = Ps;
    Ps = cov + gain * (Ps - predicted_cov) * gain.transpose();
    smoothed_out = Ps;
    smoothed_valid = true;
  }
};

// The Rauch-Tung-Striebel smoother (the forward filter, then the backward
// pass) into position, velocity and acceleration (times `scale`), and each
// sample's smoothed velocity standard deviation (noise units). The filtered
// states are kept for one chunk of samples at a time: the forward pass keeps
// the state at each chunk's start, and the backward pass forms each chunk's
// states again from there (the same operations, so the same values). Holding
// them for the whole record took 96 bytes a sample, twice over when the two
// motion estimates run at once.
void smooth_motion(const std::vector<double>& t, const std::vector<double>& y, const JerkIntensity& q, const VelocityJumps& jumps,
                   double scale, std::vector<double>& position, std::vector<double>& velocity,
                   std::vector<double>& acceleration, std::vector<double>& velocity_sd) {
  constexpr std::size_t kChunk = 4096;
  const std::size_t n = y.size(), chunks = (n + kChunk - 1) / kChunk;
  std::vector<FilterState> chunk_start(chunks);
  FilterState state = prior_state(t, y);
  CovarianceStep memo;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % kChunk == 0) chunk_start[i / kChunk] = state;
    filter_step(t, y, q.at(i), jumps, i, state, memo);
  }
  position.resize(n);
  velocity.resize(n);
  acceleration.resize(n);
  velocity_sd.resize(n);
  std::vector<FilterState> filtered(std::min(n, kChunk));
  Vec3 next_smooth = Vec3::Zero();
  Mat3 Ps = Mat3::Zero();
  SmootherStep back;
  for (std::size_t c = chunks; c-- > 0;) {
    const std::size_t first = c * kChunk, last = std::min(n, first + kChunk);
    state = chunk_start[c];
    for (std::size_t i = first; i < last; ++i) {
      filter_step(t, y, q.at(i), jumps, i, state, memo);
      filtered[i - first] = state;
    }
    for (std::size_t i = last; i-- > first;) {
      const FilterState& f = filtered[i - first];
      Vec3 smooth;
      if (i == n - 1) {
        smooth = f.mean;
        Ps = f.cov;
      } else {
        back.update(t[i + 1] - t[i], q.at(i + 1), jumps, i + 1, f.cov);
        const Vec3 predicted_mean = back.F * f.mean;
        smooth = f.mean + back.gain * (next_smooth - predicted_mean);
        back.smoothed_covariance(f.cov, Ps);
      }
      velocity_sd[i] = std::sqrt(std::max(Ps(1, 1), 0.0));
      position[i] = smooth(0) * scale;
      velocity[i] = smooth(1) * scale;
      acceleration[i] = smooth(2) * scale;
      next_smooth = smooth;
    }
  }
}

// The log jerk intensity of largest likelihood ll(log q): a log grid from a
// jerk that moves the position by 1e-3 noise widths over the record to one
// that moves it by 1e3 widths per sample, then golden section.
template <class LogLikelihood>
double max_likelihood_log_jerk(double span, double dt, LogLikelihood ll) {
  const double lo = std::log(1e-6 / std::pow(span, 5)), hi = std::log(1e6 / std::pow(dt, 5));
  const int grid = 16;
  double best_lq = lo, best = -std::numeric_limits<double>::infinity();
  for (int k = 0; k <= grid; ++k) {
    const double lq = lo + (hi - lo) * k / grid;
    const double v = ll(lq);
    if (v > best) best = v, best_lq = lq;
  }
  double a = best_lq - (hi - lo) / grid, b = best_lq + (hi - lo) / grid;
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = ll(c), fd = ll(d);
  for (int it = 0; it < 20; ++it) {
    if (fc > fd) {
      b = d, d = c, fd = fc, c = b - g * (b - a), fc = ll(c);
    } else {
      a = c, c = d, fc = fd, d = a + g * (b - a), fd = ll(d);
    }
  }
  return 0.5 * (a + b);
}

// The jerk intensity (noise units) of largest likelihood for the record.
double max_likelihood_jerk(const std::vector<double>& t, const std::vector<double>& y, const VelocityJumps& jumps, double dt) {
  return std::exp(max_likelihood_log_jerk(t.back() - t.front(), dt, [&](double log_q) {
    return kalman(t, y, JerkIntensity{std::exp(log_q)}, jumps).log_likelihood;
  }));
}

// The chi-square (one degree) level exceeded with probability p.
double chi_square_1_quantile(double p) {
  double lo = 0, hi = 200;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (std::erfc(std::sqrt(0.5 * mid)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Samples after which the velocity jumped, by the generalised likelihood
// ratio test of Willsky and Jones (1976, IEEE Trans. Autom. Control 21): a
// jump nu after sample j - 1 leaves in the innovations that follow a
// signature g_k nu the filter's gains determine, so nu's estimate and the
// test l(j) = (sum g_k e_k / s_k)^2 / sum g_k^2 / s_k (chi-square, one
// degree, under no jump) come from one pass. A jump is an l above the level
// a 1 % chance over all the record's samples allows (Bonferroni) that is the
// largest within its signature's length either side: a jump's own signature
// correlates with those of its neighbours, and l has side lobes there (at
// -9 and +9 samples of a 3 -> 10 um/s step at 10 Hz, 0.14 um of noise: l
// 29.5 and 22.3 beside 136, above the level of 21.6).
struct FoundJump {
  std::size_t at = 0;      // the velocity jumps between samples at - 1 and at
  std::size_t length = 0;  // samples holding 90 % of its signature's information
  double size = 0;         // its estimate (noise units per second): the sign is what matters
};

std::vector<FoundJump> jumps_by_likelihood_ratio(const std::vector<double>& t, const FilterPass& f, const VelocityJumps& jumps) {
  const std::size_t n = t.size(), window = 200;
  const double level = chi_square_1_quantile(0.01 / static_cast<double>(n));
  std::vector<double> l(n, 0.0), size(n, 0.0);
  std::vector<std::size_t> length(n, 0);  // samples holding 90 % of the signature's information
  std::vector<double> information;
  for (std::size_t j = 1; j < n; ++j) {
    if (jumps.at[j]) continue;
    Vec3 d(0, 1, 0);
    double num = 0, den = 0;
    information.clear();
    for (std::size_t k = j; k < std::min(n, j + window); ++k) {
      const double h = t[k] - t[k - 1];
      const Vec3 dp(d(0) + h * d(1) + 0.5 * h * h * d(2), d(1) + h * d(2), d(2));
      const double g = dp(0), w = g * g / f.innovation_var[k];
      num += g * f.innovation[k] / f.innovation_var[k];
      den += w;
      information.push_back(den);
      d = dp - f.gain[k] * g;
      // The filter has taken the jump up: what is left adds nothing.
      if (k > j + 8 && w < 1e-6 * den) break;
    }
    if (!(den > 0)) continue;
    l[j] = num * num / den;
    size[j] = num / den;
    length[j] = static_cast<std::size_t>(std::lower_bound(information.begin(), information.end(), 0.9 * den) - information.begin()) + 1;
  }
  std::vector<FoundJump> found;
  for (std::size_t j = 1; j < n; ++j) {
    if (l[j] <= level) continue;
    const std::size_t from = j > length[j] ? j - length[j] : 1, to = std::min(n, j + length[j] + 1);
    if (std::all_of(l.begin() + static_cast<std::ptrdiff_t>(from), l.begin() + static_cast<std::ptrdiff_t>(to),
                    [&](double other) { return other <= l[j]; })) {
      found.push_back({j, length[j], size[j]});
    }
  }
  return found;
}

// Whether the force follows a jump of the velocity: every contact answers a
// sudden change of speed at once with a change of force of the same sign (the
// direct effect of rate-and-state friction, Dieterich 1979; LuGre's bristle
// damping). Over the jump's signature length either side, the mean force must
// move with the jump by more than the one-sided level z of its noise (force
// noise from first differences, white). On basalt velstep4 the drive's
// position surged 10 -> 14 -> 10 um/s twice a few seconds after its step,
// with no force change (-0.0001 in mu where a = 0.013 gives +0.0046).
bool force_follows(const std::vector<double>& force, double force_noise, const FoundJump& jump, double z) {
  const std::size_t n = force.size(), w = std::max<std::size_t>(jump.length, 1);
  if (jump.at < w || jump.at + w > n) return true;  // at an edge: no force to judge by
  double before = 0, after = 0;
  for (std::size_t k = 0; k < w; ++k) {
    before += force[jump.at - 1 - k];
    after += force[jump.at + k];
  }
  const double change = (after - before) / static_cast<double>(w);
  const double along = jump.size > 0 ? change : -change;
  return along > z * force_noise * std::sqrt(2.0 / static_cast<double>(w));
}

// White-noise RMS of a force from its first differences (median absolute
// value: the steps and transients stay out of it).
double first_difference_noise(const std::vector<double>& y) {
  std::vector<double> d;
  d.reserve(y.size());
  for (std::size_t i = 1; i < y.size(); ++i) d.push_back(std::abs(y[i] - y[i - 1]));
  return median(d) / 0.6745 / std::sqrt(2.0);
}


}  // namespace

double third_difference_noise(const std::vector<double>& y) {
  if (y.size() < 8) return 0;
  std::vector<double> d;
  d.reserve(y.size());
  for (std::size_t i = 3; i < y.size(); ++i) d.push_back(std::abs(y[i] - 3 * y[i - 1] + 3 * y[i - 2] - y[i - 3]));
  // Median absolute value of a normal variable is 0.6745 sigma.
  return median(d) / 0.6745 / std::sqrt(20.0);
}

double resolution_of(const std::vector<double>& y) {
  double best = std::numeric_limits<double>::infinity();
  double scale = 0;
  for (double v : y) scale = std::max(scale, std::abs(v));
  for (std::size_t i = 1; i < y.size(); ++i) {
    const double d = std::abs(y[i] - y[i - 1]);
    if (d > 1e-12 * scale) best = std::min(best, d);
  }
  return std::isfinite(best) ? best : 0.0;
}

namespace {

// The position's noise floor: the third differences' (never below the
// resolution / sqrt(12)); a noiseless record a billionth of its scale.
double noise_floor(const std::vector<double>& x, double resolution) {
  double noise = std::max(third_difference_noise(x), resolution / std::sqrt(12.0));
  if (!(noise > 0)) {
    double scale = 0;
    for (double v : x) scale = std::max(scale, std::abs(v));
    noise = std::max(1e-9 * scale, 1e-15);
  }
  return noise;
}

}  // namespace

MotionEstimate estimate_motion(const std::vector<double>& t, const std::vector<double>& x, bool velocity_jumps,
                               const std::vector<double>& force) {
  MotionEstimate out;
  out.estimator = velocity_jumps ? "rts_constant_acceleration_with_velocity_jumps" : "rts_constant_acceleration";
  const std::size_t n = x.size();
  out.position_resolution_m = resolution_of(x);
  const double noise = noise_floor(x, out.position_resolution_m);
  out.position_noise_m = noise;
  std::vector<double> y(n);
  for (std::size_t i = 0; i < n; ++i) y[i] = x[i] / noise;
  if (n < 4) {
    out.position_m = x;
    out.velocity_m_per_s.assign(n, 0.0);
    out.acceleration_m_per_s2.assign(n, 0.0);
    return out;
  }
  const double dt = median_step(t);
  // The jerk intensity with the velocity jumps found so far, then the jumps
  // it reveals (a step smoothed over by a jerk raised to follow it), twice.
  // A jump's prior is diffuse, a hundred times the largest one-sample speed:
  // its size is the data's, not drawn towards none.
  VelocityJumps jumps;
  jumps.at.assign(n, 0);
  for (std::size_t i = 1; i < n && velocity_jumps; ++i) {
    const double v = 100 * std::fabs(y[i] - y[i - 1]) / std::max(t[i] - t[i - 1], 1e-12);
    jumps.variance = std::max(jumps.variance, v * v);
  }
  double q = max_likelihood_jerk(t, y, jumps, dt);
  const bool judge_by_force = force.size() == n;
  const double force_noise = judge_by_force ? first_difference_noise(force) : 0.0;
  // A jump the force did not follow is not tested again when the next pass
  // finds it (or its neighbour within its length): a second look at the same
  // force would be a second chance for its noise.
  std::vector<FoundJump> not_followed;
  const auto judged_before = [&](const FoundJump& j) {
    return std::any_of(not_followed.begin(), not_followed.end(), [&](const FoundJump& r) {
      return (j.at > r.at ? j.at - r.at : r.at - j.at) <= r.length;
    });
  };
  for (int pass = 0; pass < (velocity_jumps ? 2 : 0); ++pass) {
    const auto found = jumps_by_likelihood_ratio(t, kalman(t, y, JerkIntensity{q}, jumps, true), jumps);
    // One-sided, a 1 % chance over the jumps tested.
    const double z = std::sqrt(chi_square_1_quantile(0.02 / static_cast<double>(std::max<std::size_t>(found.size(), 1))));
    bool added = false;
    for (const FoundJump& j : found) {
      if (judge_by_force && judged_before(j)) continue;
      if (judge_by_force && !force_follows(force, force_noise, j, z)) {
        not_followed.push_back(j);
        continue;
      }
      jumps.at[j.at] = 1;
      added = true;
    }
    if (!added) break;
    q = max_likelihood_jerk(t, y, jumps, dt);
  }
  out.velocity_jumps_force_did_not_follow = static_cast<int>(not_followed.size());
  out.jerk_intensity = q * noise * noise;
  for (std::size_t i = 0; i < n; ++i) {
    if (jumps.at[i]) out.velocity_jumps.push_back(i);
  }
  std::vector<double> velocity_sd;
  smooth_motion(t, y, JerkIntensity{q}, jumps, noise, out.position_m, out.velocity_m_per_s, out.acceleration_m_per_s2,
                velocity_sd);
  out.velocity_std_m_per_s = median(velocity_sd) * noise;
  return out;
}

std::vector<std::size_t> setpoint_stretches(const std::vector<double>& t, const std::vector<double>& r) {
  const std::size_t n = std::min(t.size(), r.size());
  std::vector<std::size_t> starts;
  if (n == 0) return starts;
  starts.push_back(0);
  if (n < 3) return starts;
  std::vector<double> slope(n - 1);
  double steepest = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    slope[i] = (r[i + 1] - r[i]) / std::max(t[i + 1] - t[i], 1e-300);
    steepest = std::max(steepest, std::fabs(slope[i]));
  }
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double change = std::fabs(slope[i] - slope[i - 1]);
    const double level = kStretchSlopeChange * std::max(std::fabs(slope[i]), std::fabs(slope[i - 1])) + kStretchSlopeFloor * steepest;
    if (change > level) starts.push_back(i);
  }
  return starts;
}

MotionEstimate estimate_motion_by_stretches(const std::vector<double>& t, const std::vector<double>& x,
                                            const std::vector<double>& r) {
  const std::size_t n = x.size();
  if (r.size() != n || n < 4) return estimate_motion(t, x);
  MotionEstimate out;
  out.estimator = "rts_constant_acceleration_by_setpoint_stretches";
  out.position_resolution_m = resolution_of(x);
  const double noise = noise_floor(x, out.position_resolution_m);
  out.position_noise_m = noise;
  std::vector<double> y(n);
  for (std::size_t i = 0; i < n; ++i) y[i] = x[i] / noise;
  const double dt = median_step(t);
  const VelocityJumps none;
  // Each stretch long enough gets its own intensity. The samples between
  // them (a ramp's, where the setpoint's slope changes every sample) take
  // one intensity together, of largest likelihood with the others held: the
  // record's would be too low for the change of speed they carry, which then
  // leaks into the still stretch beside them.
  std::vector<double> q(n, 0.0);
  std::vector<char> between(n, 0);
  const std::vector<std::size_t> starts = setpoint_stretches(t, r);
  for (std::size_t k = 0; k < starts.size(); ++k) {
    const auto first = static_cast<std::ptrdiff_t>(starts[k]);
    const auto last = static_cast<std::ptrdiff_t>(k + 1 < starts.size() ? starts[k + 1] : n);
    if (static_cast<std::size_t>(last - first) < kStretchMinForItsOwnJerk) {
      std::fill(between.begin() + first, between.begin() + last, 1);
      continue;
    }
    const std::vector<double> ts(t.begin() + first, t.begin() + last), ys(y.begin() + first, y.begin() + last);
    std::fill(q.begin() + first, q.begin() + last, max_likelihood_jerk(ts, ys, none, dt));
  }
  if (std::find(between.begin(), between.end(), 1) != between.end()) {
    const auto with = [&](double log_q) {
      const double qb = std::exp(log_q);
      for (std::size_t i = 0; i < n; ++i) {
        if (between[i]) q[i] = qb;
      }
    };
    with(max_likelihood_log_jerk(t.back() - t.front(), dt, [&](double log_q) {
      with(log_q);
      return kalman(t, y, JerkIntensity{0.0, &q}, none).log_likelihood;
    }));
  }
  out.jerk_intensity = median(q) * noise * noise;
  std::vector<double> velocity_sd;
  smooth_motion(t, y, JerkIntensity{0.0, &q}, none, noise, out.position_m, out.velocity_m_per_s, out.acceleration_m_per_s2,
                velocity_sd);
  out.velocity_std_m_per_s = median(velocity_sd) * noise;
  return out;
}

namespace {

// The step of a record sampled uniformly enough for an impulse response on
// the sample grid (every step within 1 % of the median), or 0.
double uniform_step(const std::vector<double>& t) {
  const double dt = median_step(t);
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (std::fabs(t[i] - t[i - 1] - dt) > 0.01 * dt) return 0;
  }
  return dt;
}

// The loop model's regression: x[i] ~ sum_k h_k r[i - k] + c, k from -lead
// to lag: any linear loop whose response settles within the window (0.2 s,
// at most 200 taps), a few taps of lead for a clock skew between the
// channels; with the force, also its taps (kForceTaps).
//
// Given the force (--motion-estimator rts_loop_force), the friction force
// is the loop's other input: a finite servo stiffness lets the tip yield to
// it (by F / k_servo). Left out, that yield goes to the smoother, which
// rounds off its jumps at reversals, and the presliding displacement comes
// out larger than it was (contact stiffness 2-9 % low on the independent
// generator). Within a few samples only: a 0.2 s force window also fits
// slow friction changes into the motion (measured on the generator's clean
// files: the Stribeck velocity then 2-21 % low, 3 of 10 files accepting an
// effect).
//
// Each column is a window of n samples sliding along a padded channel (the
// record's ends repeated): reference tap c (c = k + lead) reads r[i - k] -
// r0 at reference_padded[taps - 1 - c + i]; force tap k reads force[i - k]
// at force_padded[force_taps - 1 - k + i], in units of one magnitude with
// the reference (metres and newtons); the last column is the constant.
struct LoopColumns {
  int lead = 4, lag = 0, taps = 0, force_taps = 0;
  double force_unit = 1.0, r0 = 0;
  std::vector<double> reference_padded, force_padded, ones;

  Eigen::Index count() const { return taps + force_taps + 1; }
  std::vector<const double*> columns() const {
    std::vector<const double*> c;
    for (int k = 0; k < taps; ++k) c.push_back(reference_padded.data() + (taps - 1 - k));
    for (int k = 0; k < force_taps; ++k) c.push_back(force_padded.data() + (force_taps - 1 - k));
    c.push_back(ones.data());
    return c;
  }
  double reference_tap(int c, std::size_t i) const { return reference_padded[static_cast<std::size_t>(taps - 1 - c) + i]; }
  double force_tap(int k, std::size_t i) const { return force_padded[static_cast<std::size_t>(force_taps - 1 - k) + i]; }
};

LoopColumns loop_columns(const std::vector<double>& r, const std::vector<double>& force, double dt) {
  const std::size_t n = r.size();
  LoopColumns l;
  l.lag = std::clamp(static_cast<int>(std::lround(0.2 / dt)), 8, 200);
  l.taps = l.lead + l.lag + 1;
  l.force_taps = force.size() == n ? kForceTaps : 0;
  double force_scale = 0, reference_scale = 0;
  for (std::size_t i = 0; i < n && l.force_taps > 0; ++i) {
    force_scale = std::max(force_scale, std::fabs(force[i]));
    reference_scale = std::max(reference_scale, std::fabs(r[i] - r[0]));
  }
  // Columns of one magnitude for the normal equations (metres and newtons).
  l.force_unit = force_scale > 0 && reference_scale > 0 ? reference_scale / force_scale : 1.0;
  l.r0 = r[0];
  l.reference_padded.resize(n + static_cast<std::size_t>(l.taps) - 1);
  for (std::size_t j = 0; j < l.reference_padded.size(); ++j) {
    const long i = static_cast<long>(j) - l.lag;
    l.reference_padded[j] = (i < 0 ? r[0] : (i >= static_cast<long>(n) ? r[n - 1] : r[static_cast<std::size_t>(i)])) - l.r0;
  }
  l.force_padded.resize(l.force_taps > 0 ? n + static_cast<std::size_t>(l.force_taps) - 1 : 0);
  for (std::size_t j = 0; j < l.force_padded.size(); ++j) {
    const long i = static_cast<long>(j) - (l.force_taps - 1);
    l.force_padded[j] = l.force_unit * (i < 0 ? force[0] : force[static_cast<std::size_t>(i)]);
  }
  l.ones.assign(n, 1.0);
  return l;
}

}  // namespace

std::optional<Eigen::MatrixXd> loop_normal_matrix(const std::vector<double>& t, const std::vector<double>& r,
                                                  const std::vector<double>& force, unsigned threads) {
  const std::size_t n = r.size();
  if (t.size() != n || n < 400 || force.size() != n) return std::nullopt;
  const double dt = uniform_step(t);
  if (!(dt > 0)) return std::nullopt;
  const LoopColumns l = loop_columns(r, force, dt);
  return gram_in_sample_order(l.columns(), n, threads);
}

MotionEstimate estimate_motion_with_reference(const std::vector<double>& t, const std::vector<double>& x,
                                              const std::vector<double>& r, const std::vector<double>& force,
                                              bool velocity_jumps, const std::vector<double>& force_for_jumps,
                                              const Eigen::MatrixXd* normal_matrix) {
  const std::size_t n = x.size();
  if (r.size() != n || n < 400) return estimate_motion(t, x, velocity_jumps, force_for_jumps);
  const double dt = uniform_step(t);
  if (!(dt > 0)) return estimate_motion(t, x, velocity_jumps, force_for_jumps);
  LoopColumns l = loop_columns(r, force, dt);
  const int taps = l.taps, force_taps = l.force_taps;
  const Eigen::Index cols = l.count();
  const auto fill_row = [&](std::size_t i, Eigen::VectorXd& row) {
    for (int c = 0; c < taps; ++c) row[c] = l.reference_tap(c, i);
    for (int k = 0; k < force_taps; ++k) row[taps + k] = l.force_tap(k, i);
    row[taps + force_taps] = 1.0;
  };
  // The normal equations summed in sample order, each element as a rank-one
  // update per sample would sum it. Forming them from sums over the windows
  // and shifting those by a sample is cheaper (a few percent of the
  // diagnosis' CPU) but sums in another order; the reference taps are nearly
  // collinear, and that rounding moved the final model of an 800 s record
  // past its standard errors. A matrix formed once with the force taps
  // (loop_normal_matrix) holds the model without them as its
  // reference-and-constant part: each element is the same sum.
  Eigen::MatrixXd xtx;
  const Eigen::Index shared_cols = static_cast<Eigen::Index>(taps) + kForceTaps + 1;
  if (normal_matrix && normal_matrix->rows() == shared_cols && (force_taps == 0 || force_taps == kForceTaps)) {
    if (force_taps > 0) {
      xtx = *normal_matrix;
    } else {
      std::vector<Eigen::Index> keep(static_cast<std::size_t>(taps));
      for (int c = 0; c < taps; ++c) keep[static_cast<std::size_t>(c)] = c;
      keep.push_back(shared_cols - 1);
      xtx = (*normal_matrix)(keep, keep);
    }
  } else {
    xtx = gram_in_sample_order(l.columns(), n, 1);
  }
  std::vector<double>().swap(l.ones);
  Eigen::VectorXd xty = Eigen::VectorXd::Zero(cols);
  Eigen::VectorXd row(cols);
  for (std::size_t i = 0; i < n; ++i) {
    fill_row(i, row);
    xty += row * (x[i] - l.r0);
  }
  const Eigen::VectorXd coef = xtx.ldlt().solve(xty);
  std::vector<double> e(n);  // the loop model's residual
  std::vector<double> xm(n);
  double mean_x = 0, tss = 0, sse = 0;
  for (double v : x) mean_x += v;
  mean_x /= static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i) {
    double value = coef[taps + force_taps];
    for (int c = 0; c < taps; ++c) value += coef[c] * l.reference_tap(c, i);
    for (int k = 0; k < force_taps; ++k) value += coef[taps + k] * l.force_tap(k, i);
    xm[i] = value + l.r0;
    tss += (x[i] - mean_x) * (x[i] - mean_x);
    sse += (x[i] - xm[i]) * (x[i] - xm[i]);
  }
  std::vector<double>().swap(l.reference_padded);
  std::vector<double>().swap(l.force_padded);
  if (!(tss > 0) || !std::isfinite(sse) || sse > 0.1 * tss) return estimate_motion(t, x, velocity_jumps, force_for_jumps);
  for (std::size_t i = 0; i < n; ++i) e[i] = x[i] - xm[i];
  MotionEstimate out = estimate_motion(t, e, velocity_jumps, force_for_jumps);
  // The noise floor and resolution belong to the record's position.
  out.position_resolution_m = resolution_of(x);
  out.position_noise_m = std::max(third_difference_noise(x), out.position_resolution_m / std::sqrt(12.0));
  std::vector<double>().swap(e);
  // The loop model's motion is noise-free: its derivatives by differences.
  for (std::size_t i = 0; i < n; ++i) {
    out.position_m[i] += xm[i];
    if (i == 0 || i + 1 == n) continue;
    out.velocity_m_per_s[i] += (xm[i + 1] - xm[i - 1]) / (t[i + 1] - t[i - 1]);
    out.acceleration_m_per_s2[i] += (xm[i + 1] - 2 * xm[i] + xm[i - 1]) / (dt * dt);
  }
  out.estimator = std::string(force_taps > 0 ? "rts_constant_acceleration_on_reference_and_force_loop_residual"
                                              : "rts_constant_acceleration_on_reference_loop_residual") +
                  (velocity_jumps ? "_with_velocity_jumps" : "");
  out.loop_taps = taps;
  out.loop_force_taps = force_taps;
  for (int k = 0; k < force_taps; ++k) out.loop_force_response_m_per_n += coef[taps + k] * l.force_unit;
  out.loop_variance_explained = 1.0 - sse / tss;
  return out;
}

}  // namespace tribo::analysis
