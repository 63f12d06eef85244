#include "analysis/effects/creep_in_holds.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/printf.h>

#include "analysis/effects/detectability.h"
#include "analysis/effects/regression.h"

namespace tribo::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kOneRate = "one rate in every hold";
constexpr const char* kLinearRate = "a rate changing linearly over the holds";

// The first sample of a hold past its settling time (the stop's transient).
std::size_t first_settled(const MeasuredSeries& s, const Hold& h, const CreepInHoldsOptions& options) {
  std::size_t i = h.first;
  while (i < h.last && s.time_s[i] < s.time_s[h.first] + options.settle_s) ++i;
  return i;
}

// The mean time of a hold's settled samples, about which its slope is fitted.
double settled_mean_time_s(const MeasuredSeries& s, const Hold& h, const CreepInHoldsOptions& options) {
  const std::size_t from = first_settled(s, h, options);
  double sum = 0;
  for (std::size_t i = from; i <= h.last; ++i) sum += s.time_s[i];
  return sum / static_cast<double>(h.last - from + 1);
}

// The force's slope in one hold after its settling time; duration 0 when the
// hold is too short or the slope not determined.
HoldSlope hold_slope(const MeasuredSeries& s, const Hold& h, const CreepInHoldsOptions& options) {
  HoldSlope out;
  const double start = s.time_s[h.first];
  out.start_s = start;
  out.duration_s = s.time_s[h.last] - start;
  if (out.duration_s < options.min_hold_s) return HoldSlope{};
  const std::size_t from = first_settled(s, h, options);
  const double mean_t = settled_mean_time_s(s, h, options);
  Design d;
  for (std::size_t i = from; i <= h.last; ++i) d.add_row({1.0, s.time_s[i] - mean_t}, s.force_n[i]);
  const Regression r = d.fit();
  if (!r.ok) return HoldSlope{};
  out.mean_force = r.coef[0];
  out.slope_per_s = r.coef[1];
  out.slope_std_error = r.std_error[1];
  // A held force that levels off: the contact has reached its friction level
  // and slips at the creep speed instead of loading (0.3 nm/s pushes 1 uN/s
  // into a 3415 N/m contact; 150 s of 1 nm/s would load it by 512 uN, past
  // the 300 uN it holds at 3000 uN). Curvature against the slope.
  Design q;
  const double half = 0.5 * (out.duration_s - options.settle_s);
  for (std::size_t i = from; i <= h.last; ++i) {
    const double u = (s.time_s[i] - mean_t) / half;
    q.add_row({1.0, u, u * u}, s.force_n[i]);
  }
  const Regression c = q.fit();
  out.levels_off = c.ok && c.coef[2] * out.slope_per_s < 0 && std::fabs(c.t(2)) >= 3.0 &&
                   std::fabs(c.coef[2]) > 0.25 * std::fabs(out.slope_per_s) * half;
  return out;
}

struct LineFit {
  Eigen::VectorXd coef, std_error;
  bool ok = false;
};

// Ordinary least squares with errors from the rows' scatter (each row one
// independent observation: a hold, a pass).
LineFit least_squares(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  LineFit out;
  const Eigen::Index n = x.rows(), k = x.cols();
  if (n <= k) return out;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(x);
  if (qr.rank() < k) return out;
  out.coef = qr.solve(y);
  const double s2 = (y - x * out.coef).squaredNorm() / static_cast<double>(n - k);
  const Eigen::MatrixXd cov = s2 * (x.transpose() * x).inverse();
  out.std_error = cov.diagonal().cwiseSqrt();
  out.ok = true;
  return out;
}

// How much of the holds' force change the passes carry. A drift of the
// force reading shifts every later force by what it shifted the holds; a
// creep under a stuck contact is forgotten once the contact slides. Each
// pass's force (its second half's mean, past the break-away) is regressed on
// an offset and a friction level (times the direction) per load, and on
// D(t), the holds' force change accumulated before it (each long hold's slope
// times its duration): the coefficient is 1 for a reading drift, 0 for a
// creep. Not determined (NaN) with too few passes.
void reading_drift_share(const MeasuredSeries& s, const MotionSegmentation& m, const std::vector<Hold>& long_holds,
                         CreepInHolds& out) {
  out.reading_share = out.reading_share_std_error = out.reading_rate_per_s = out.reading_rate_std_error = kNaN;
  // Passes that slide: a step of a few hundred nm (a step back that unloads
  // the contact before a hold) stays in presliding, where the force is not the
  // friction level.
  double longest = 0;
  for (const Pass& p : m.passes) longest = std::max(longest, std::fabs(s.position_m[p.last] - s.position_m[p.first]));
  std::vector<Pass> sliding;
  int levels = 0;
  for (const Pass& p : m.passes) {
    if (std::fabs(s.position_m[p.last] - s.position_m[p.first]) < 0.25 * longest) continue;
    sliding.push_back(p);
    levels = std::max(levels, p.load_level + 1);
  }
  const auto rows = static_cast<Eigen::Index>(sliding.size());
  const Eigen::Index cols = 2 * levels + 1;
  if (rows < cols + 2) return;
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(rows, cols);
  Eigen::VectorXd y(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Pass& p = sliding[static_cast<std::size_t>(r)];
    const std::size_t mid = (p.first + p.last) / 2;
    double sum = 0;
    for (std::size_t i = mid; i <= p.last; ++i) sum += s.force_n[i];
    y[r] = sum / static_cast<double>(p.last - mid + 1);
    x(r, 2 * p.load_level) = 1.0;
    x(r, 2 * p.load_level + 1) = p.direction;
    double accumulated = 0;
    for (std::size_t k = 0; k < long_holds.size(); ++k) {
      if (long_holds[k].last < p.first) accumulated += out.holds[k].slope_per_s * out.holds[k].duration_s;
    }
    x(r, cols - 1) = accumulated;
  }
  // Load levels without passes leave empty columns: drop them.
  std::vector<Eigen::Index> used;
  for (Eigen::Index c = 0; c < cols; ++c) {
    if (x.col(c).cwiseAbs().sum() > 0) used.push_back(c);
  }
  if (used.empty() || used.back() != cols - 1) return;  // no hold before any pass
  Eigen::MatrixXd xu(rows, static_cast<Eigen::Index>(used.size()));
  for (std::size_t c = 0; c < used.size(); ++c) xu.col(static_cast<Eigen::Index>(c)) = x.col(used[c]);
  const LineFit fit = least_squares(xu, y);
  if (!fit.ok) return;
  out.reading_share = fit.coef[xu.cols() - 1];
  out.reading_share_std_error = fit.std_error[xu.cols() - 1];
  // The passes' own drift over time, in the same design: a reading drift's
  // rate, whatever the holds do.
  for (Eigen::Index r = 0; r < rows; ++r) {
    const Pass& p = sliding[static_cast<std::size_t>(r)];
    xu(r, xu.cols() - 1) = 0.5 * (s.time_s[p.first] + s.time_s[p.last]);
  }
  const LineFit in_time = least_squares(xu, y);
  if (!in_time.ok) return;
  out.reading_rate_per_s = in_time.coef[xu.cols() - 1];
  out.reading_rate_std_error = in_time.std_error[xu.cols() - 1];
}

// The stuck contact's stiffness from the start of the holds: while the
// position loop brings the plate to rest after the stop (settle_s), the tip
// moves tens of nm against the stuck contact and the force follows it
// elastically, dF/dx (the median over the holds). NaN when fewer than half
// the long holds move by more than five position noise floors there.
struct Stiffness {
  double value = kNaN, std_error = kNaN;
  std::size_t holds = 0;
};

Stiffness settling_stiffness(const MeasuredSeries& s, const std::vector<Hold>& long_holds, const CreepInHoldsOptions& options) {
  const double floor = std::max(s.position_noise_m, s.position_resolution_m);
  std::vector<double> stiffness;
  for (const Hold& h : long_holds) {
    Design d;
    double low = s.position_m[h.first], high = low;
    for (std::size_t i = h.first, end = first_settled(s, h, options); i < end; ++i) {
      d.add_row({1.0, s.position_m[i]}, s.force_n[i]);
      low = std::min(low, s.position_m[i]);
      high = std::max(high, s.position_m[i]);
    }
    if (high - low < 5 * floor) continue;
    const Regression r = d.fit();
    if (r.ok && r.coef[1] > 0) stiffness.push_back(r.coef[1]);
  }
  Stiffness out;
  if (stiffness.size() < 2 || 2 * stiffness.size() < long_holds.size()) return out;
  out.holds = stiffness.size();
  double mean = 0, var = 0;
  for (double k : stiffness) mean += k;
  mean /= static_cast<double>(stiffness.size());
  for (double k : stiffness) var += (k - mean) * (k - mean);
  var /= static_cast<double>(stiffness.size() - 1);
  std::nth_element(stiffness.begin(), stiffness.begin() + static_cast<std::ptrdiff_t>(stiffness.size() / 2), stiffness.end());
  out.value = stiffness[stiffness.size() / 2];
  // The median's error for a normal sample: sqrt(pi / 2) times the mean's.
  out.std_error = 1.2533 * std::sqrt(var / static_cast<double>(stiffness.size()));
  return out;
}

// Leave one hold out: each hold's slope as predicted without it
// (predicted[k]), against the pass model's constant held force (slope 0),
// over each hold's settled samples about its own mean (the slope fit's
// intercept, the time axis being centred there).
void leave_one_hold_out(const MeasuredSeries& s, const std::vector<Hold>& long_holds, const CreepInHoldsOptions& options,
                        const Eigen::VectorXd& predicted, CreepInHolds& out) {
  double before = 0, after = 0, improved = 0, changed = 0, samples = 0;
  for (std::size_t k = 0; k < long_holds.size(); ++k) {
    const Hold& hold = long_holds[k];
    const double slope = predicted[static_cast<Eigen::Index>(k)];
    const double mean_t = settled_mean_time_s(s, hold, options), mean_f = out.holds[k].mean_force;
    double ss0 = 0, ss1 = 0;
    for (std::size_t i = first_settled(s, hold, options); i <= hold.last; ++i) {
      const double r0 = s.force_n[i] - mean_f;
      const double r1 = r0 - slope * (s.time_s[i] - mean_t);
      ss0 += r0 * r0;
      ss1 += r1 * r1;
      samples += 1;
    }
    before += ss0;
    after += ss1;
    changed += std::fabs(ss0 - ss1);
    if (ss1 < ss0) improved += ss0 - ss1;
  }
  out.heldout_rms_before = samples > 0 ? std::sqrt(before / samples) : 0.0;
  out.heldout_rms_after = samples > 0 ? std::sqrt(after / samples) : 0.0;
  out.heldout_gain = before > 0 ? 1.0 - std::sqrt(after / before) : 0.0;
  out.block_agreement = changed > 0 ? improved / changed : 0.0;
}

// Each row's prediction from the least-squares fit of the other rows.
Eigen::VectorXd leave_one_out(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  const Eigen::Index n = x.rows();
  Eigen::VectorXd predicted = Eigen::VectorXd::Constant(n, kNaN);
  for (Eigen::Index j = 0; j < n; ++j) {
    Eigen::MatrixXd xj(n - 1, x.cols());
    Eigen::VectorXd yj(n - 1);
    for (Eigen::Index i = 0, r = 0; i < n; ++i) {
      if (i == j) continue;
      xj.row(r) = x.row(i);
      yj[r++] = y[i];
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(xj);
    if (qr.rank() < x.cols()) return predicted;
    predicted[j] = x.row(j).dot(qr.solve(yj));
  }
  return predicted;
}

double squared_error(const Eigen::VectorXd& predicted, const Eigen::VectorXd& y) {
  return predicted.allFinite() ? (predicted - y).squaredNorm() : std::numeric_limits<double>::infinity();
}

// The form the holds' drift takes, or why none: a form other than kNone,
// with an empty reason, when accepted.
struct Judgement {
  HoldDriftForm form = HoldDriftForm::kNone;
  std::string reason;
};

Judgement judge(const CreepInHolds& c, const CreepInHoldsOptions& options, double creep_cv, double drain_cv) {
  if (!(c.strength_z >= options.min_strength_z)) {
    return {HoldDriftForm::kNone, fmt::sprintf("the held force's slopes (%s) stand %.1f standard errors from none (below %.0f)",
                                               c.creep_model, c.strength_z, options.min_strength_z)};
  }
  if (drain_cv < creep_cv) {
    return {HoldDriftForm::kNone,
            fmt::sprintf("the held force relaxes towards zero: its slopes follow it (%.3g +- %.3g per s of held force) "
                         "better than a drift does, held out hold by hold; the contact drains",
                         c.drain_per_s, c.drain_std_error)};
  }
  if (!std::isfinite(c.reading_share)) {
    return {HoldDriftForm::kNone, "too few passes after the holds to tell a creep from a drift of the force reading"};
  }
  const double from_creep = std::fabs(c.reading_share) / c.reading_share_std_error;
  const double from_reading = std::fabs(c.reading_share - 1.0) / c.reading_share_std_error;
  HoldDriftForm form = HoldDriftForm::kNone;
  if (from_reading < 2.0 && from_creep >= 2.0) form = HoldDriftForm::kReading;
  if (from_creep < 2.0 && from_reading >= 2.0) form = HoldDriftForm::kCreep;
  if (form == HoldDriftForm::kNone && from_creep >= 2.0 && from_reading >= 2.0 && std::isfinite(c.reading_rate_per_s)) {
    // Part of it: the passes drift at their own rate, the holds at the
    // creep's and that rate together.
    const double creep = c.creep_rate_per_s - c.reading_rate_per_s;
    const double creep_z = std::fabs(creep) / std::hypot(c.creep_rate_std_error, c.reading_rate_std_error);
    const double reading_z = std::fabs(c.reading_rate_per_s) / c.reading_rate_std_error;
    if (creep_z >= options.min_strength_z && reading_z >= options.min_strength_z) form = HoldDriftForm::kCreepAndReading;
  }
  if (form == HoldDriftForm::kNone) {
    return {form, fmt::sprintf("the passes carry %.2f +- %.2f of the holds' force change, %s", c.reading_share,
                               c.reading_share_std_error,
                               from_creep < 2.0 ? "not told from none (a creep) or all (a drift of the force reading)"
                                                : "neither none (a creep) nor all (a drift of the force reading)")};
  }
  if (c.heldout_gain < options.min_heldout_gain || c.block_agreement < options.min_block_agreement) {
    return {HoldDriftForm::kNone,
            fmt::sprintf("did not clearly help on held-out holds: RMS %+.2f %%, %.0f %% of the change in improved holds",
                         -100 * c.heldout_gain, 100 * c.block_agreement)};
  }
  return {form, {}};
}

// How many standard errors from none the creep's coefficients stand, as the
// normal deviate of their joint (Wald) test's p-value.
double strength_of(const LineFit& fit, const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  if (fit.coef.size() == 1) return fit.std_error[0] > 0 ? std::fabs(fit.coef[0]) / fit.std_error[0] : 0.0;
  const Eigen::Index n = x.rows(), k = x.cols();
  const double s2 = (y - x * fit.coef).squaredNorm() / static_cast<double>(n - k);
  const double wald = fit.coef.dot((x.transpose() * x) * fit.coef) / s2;
  const double p = std::max(std::exp(-0.5 * wald), 1e-300);  // chi-square with 2 degrees of freedom
  return -normal_quantile(0.5 * p);
}

// The creep speed -rate / k. Where some holds level off (the contact at its
// friction level, slipping at the creep speed instead of loading), the rate
// is the mean slope of the others when at least two remain, its error from
// their scatter and their own errors; else the mean over every hold, then a
// lower bound (at 1 nm/s on the default instrument six of eight holds level
// off and the mean gives 0.59-0.68 nm/s). With a reading drift too, the
// passes' drift rate is the reading's part of every hold's slope.
void set_speed(CreepInHolds& out) {
  const double k = out.stiffness_per_m;
  std::vector<const HoldSlope*> elastic;
  for (const HoldSlope& h : out.holds) {
    if (!h.levels_off) elastic.push_back(&h);
  }
  out.levelling_holds = static_cast<int>(out.holds.size() - elastic.size());
  out.speed_holds = static_cast<int>(out.holds.size());
  double rate = out.creep_rate_per_s, error = out.creep_rate_std_error;
  const bool both = out.form == HoldDriftForm::kCreepAndReading;
  if (out.levelling_holds > 0 && elastic.size() >= 2) {
    const double m = static_cast<double>(elastic.size());
    double mean = 0, scatter = 0, own = 0;
    for (const HoldSlope* h : elastic) mean += h->slope_per_s / m;
    for (const HoldSlope* h : elastic) {
      scatter += (h->slope_per_s - mean) * (h->slope_per_s - mean) / (m - 1);
      own += h->slope_std_error * h->slope_std_error / m;
    }
    rate = mean;
    error = std::sqrt((scatter + own) / m);
    out.speed_holds = static_cast<int>(elastic.size());
  }
  if (both) {  // the creep's part of the holds' slope
    rate -= out.reading_rate_per_s;
    error = std::hypot(error, out.reading_rate_std_error);
  }
  out.creep_part_per_s = rate;
  out.creep_part_std_error = error;
  if (!(std::isfinite(k) && k > 0)) {
    out.creep_speed_m_per_s = out.creep_speed_std_error = kNaN;
    return;
  }
  out.creep_speed_m_per_s = -rate / k;
  out.creep_speed_std_error = std::fabs(out.creep_speed_m_per_s) * std::hypot(error / rate, out.stiffness_std_error / k);
}

// The report's sentence: the form named, or why none, with the numbers.
std::string verdict_text(const CreepInHolds& c, const CreepInHoldsOptions& options, const std::string& unit,
                         const std::string& reason) {
  const std::string trend =
      c.creep_model == kLinearRate ? fmt::sprintf(", changing by %.3g +- %.3g from the first hold to the last",
                                                  c.creep_trend_per_s, c.creep_trend_std_error)
                                   : "";
  const std::string evidence = fmt::sprintf(
      "the held force changes at %.3g +- %.3g %s/s on average in %zu holds of at least %.0f s%s (%s, %.1f standard "
      "errors from none; drain alternative %.3g +- %.3g per s of held force); held out (each hold from the others) RMS "
      "%+.2f %%, %.0f %% of the change in improved holds",
      c.creep_rate_per_s, c.creep_rate_std_error, unit, c.holds.size(), options.min_hold_s, trend, c.creep_model,
      c.strength_z, c.drain_per_s, c.drain_std_error, -100 * c.heldout_gain, 100 * c.block_agreement);
  std::string bound;
  if (c.levelling_holds > 0 && c.speed_holds < static_cast<int>(c.holds.size())) {
    bound = fmt::sprintf(" (from the %d holds whose force does not level off; in the other %d the contact reached its "
                         "friction level and slipped)",
                         c.speed_holds, c.levelling_holds);
  } else if (c.levelling_holds > 0) {
    bound = fmt::sprintf(" (a lower bound: in %d of the holds the held force levels off, the contact slipping at its "
                         "friction level)",
                         c.levelling_holds);
  }
  const std::string speed = std::isfinite(c.creep_speed_m_per_s)
                                ? fmt::sprintf("; mean creep speed %.3g +- %.3g m/s%s along +x (the sample against the tip, "
                                               "or the position sensor's zero, which the position loop follows), from the "
                                               "contact stiffness %.4g +- %.2g %s/m (%s)",
                                               c.creep_speed_m_per_s, c.creep_speed_std_error, bound, c.stiffness_per_m,
                                               c.stiffness_std_error, unit, c.stiffness_source)
                                : "";
  const std::string passes =
      std::isfinite(c.reading_share)
          ? fmt::sprintf("; the passes carry %.2f +- %.2f of the holds' force change (a reading drift: 1, a creep: 0)",
                         c.reading_share, c.reading_share_std_error)
          : "";
  switch (c.form) {
    case HoldDriftForm::kCreep: return "creep under a stuck contact: " + evidence + speed + passes;
    case HoldDriftForm::kReading: return "a drift of the force reading, in the holds and carried by the passes: " + evidence + passes;
    case HoldDriftForm::kCreepAndReading:
      return fmt::sprintf("creep under a stuck contact and a drift of the force reading: %s; the passes drift at %.3g +- "
                          "%.3g %s/s, the creep's part of the holds' slope is %.3g +- %.3g %s/s%s%s",
                          evidence, c.reading_rate_per_s, c.reading_rate_std_error, unit, c.creep_part_per_s,
                          c.creep_part_std_error, unit, speed, passes);
    default: return "the holds' drift is not named: " + reason + " (" + evidence + passes + ")";
  }
}

}  // namespace

CreepInHolds creep_in_holds(const MeasuredSeries& series, const MotionSegmentation& motion,
                            double model_stiffness_per_m, double model_stiffness_std_error,
                            const CreepInHoldsOptions& options) {
  CreepInHolds out;
  std::vector<Hold> long_holds;
  for (const Hold& h : motion.holds) {
    if (series.time_s[h.last] - series.time_s[h.first] < options.min_hold_s) continue;
    long_holds.push_back(h);
    HoldSlope slope = hold_slope(series, h, options);
    if (slope.duration_s <= 0) {
      out.holds.clear();
      out.verdict = "a long hold too short after its settling time for a slope";
      return out;
    }
    out.holds.push_back(slope);
  }
  if (static_cast<int>(out.holds.size()) < options.min_holds) {
    out.verdict = fmt::sprintf("%zu holds of at least %.0f s (%d needed): no creep assessed", out.holds.size(),
                               options.min_hold_s, options.min_holds);
    out.holds.clear();
    return out;
  }
  const Stiffness settled = settling_stiffness(series, long_holds, options);
  out.stiffness_per_m = std::isfinite(settled.value) ? settled.value : model_stiffness_per_m;
  out.stiffness_std_error = std::isfinite(settled.value) ? settled.std_error : model_stiffness_std_error;
  out.stiffness_source = std::isfinite(settled.value)
                             ? fmt::sprintf("dF/dx as the holds settle, the median of %zu", settled.holds)
                             : "the pass model's sigma0";
  // The creep's rate constant, or linear in time (a creep speed that wanders
  // over minutes), chosen by leave-one-hold-out prediction; the drain, a rate
  // proportional to the held force, its mimic.
  const auto n = static_cast<Eigen::Index>(out.holds.size());
  const double first = out.holds.front().start_s, last = out.holds.back().start_s + out.holds.back().duration_s;
  Eigen::MatrixXd constant(n, 1), linear(n, 2), drain(n, 1);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const HoldSlope& h = out.holds[static_cast<std::size_t>(i)];
    constant(i, 0) = linear(i, 0) = 1.0;
    linear(i, 1) = (h.start_s + 0.5 * h.duration_s - 0.5 * (first + last)) / (last - first);
    drain(i, 0) = h.mean_force;
    y[i] = h.slope_per_s;
  }
  const Eigen::VectorXd constant_loo = leave_one_out(constant, y), linear_loo = leave_one_out(linear, y);
  const bool is_linear = squared_error(linear_loo, y) < squared_error(constant_loo, y);
  const Eigen::MatrixXd& x = is_linear ? linear : constant;
  const Eigen::VectorXd& predicted = is_linear ? linear_loo : constant_loo;
  const LineFit creep = least_squares(x, y), drained = least_squares(drain, y);
  if (!creep.ok || !drained.ok) {
    out.verdict = "the holds' slopes do not determine a creep";
    out.holds.clear();
    return out;
  }
  out.creep_model = is_linear ? kLinearRate : kOneRate;
  out.creep_rate_per_s = creep.coef[0];  // the mean over the holds (the time axis is centred)
  out.creep_rate_std_error = creep.std_error[0];
  out.creep_trend_per_s = is_linear ? creep.coef[1] : 0.0;
  out.creep_trend_std_error = is_linear ? creep.std_error[1] : 0.0;
  out.strength_z = strength_of(creep, x, y);
  out.drain_per_s = drained.coef[0];
  out.drain_std_error = drained.std_error[0];
  reading_drift_share(series, motion, long_holds, out);
  leave_one_hold_out(series, long_holds, options, predicted, out);
  const Judgement judged = judge(out, options, squared_error(predicted, y), squared_error(leave_one_out(drain, y), y));
  out.form = judged.form;
  out.accepted = judged.form != HoldDriftForm::kNone;
  set_speed(out);
  out.verdict = verdict_text(out, options, series.force_unit, judged.reason);
  return out;
}

}  // namespace tribo::analysis
