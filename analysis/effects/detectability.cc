#include "analysis/effects/detectability.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace tribo::analysis {

namespace {

// At most this many rows of each kind enter the projection: enough for a
// mean square, small enough that the Jacobian costs little memory.
constexpr std::size_t kMaxRows = 20000;

// The marked rows, every k-th of them so that at most kMaxRows remain; total
// receives how many are marked.
std::vector<std::size_t> every_kth(const std::vector<char>& mask, std::size_t& total) {
  total = static_cast<std::size_t>(std::count_if(mask.begin(), mask.end(), [](char c) { return c != 0; }));
  const std::size_t stride = std::max<std::size_t>(1, (total + kMaxRows - 1) / kMaxRows);
  std::vector<std::size_t> rows;
  std::size_t seen = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) {
    if (mask[i] && seen++ % stride == 0) rows.push_back(i);
  }
  return rows;
}

double rms_at(const std::vector<double>& measured, const std::vector<double>& model, const std::vector<std::size_t>& rows) {
  double sum = 0;
  for (std::size_t i : rows) sum += (measured[i] - model[i]) * (measured[i] - model[i]);
  return rows.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(rows.size()));
}

// The parameter that carries an effect's strength, and in words how the
// extension's other parameters are set (at_strength()).
struct Axis {
  std::string parameter;
  std::string words;
};

std::optional<Axis> axis_of(Effect e) {
  switch (e) {
    case Effect::kDwellStiction: return Axis{"dwell_dFs", "dwell_dFs, time constant and memory at their starting values"};
    case Effect::kFrictionalLag: return Axis{"lag_time", "lag_time"};
    case Effect::kVelocityStrengthening: return Axis{"log_velocity_coeff", "log_velocity_coeff"};
    case Effect::kLoadDependence: return Axis{"load_exponent", "load_exponent"};
    case Effect::kDirectionAsymmetry: return Axis{"asym_levels", "asym_levels, asym_viscous 0"};
    case Effect::kTiltOffset: return Axis{"tilt_tan", "tilt_tan"};
    case Effect::kDrift: return Axis{"drift", "a linear drift over the record, the change from start to end"};
    case Effect::kBacklash: return Axis{"backlash_gap", "backlash_gap"};
    case Effect::kRateState: return Axis{"rs_a", "rs_a = rs_b (steady state unchanged), rs_dc at its starting value"};
    case Effect::kPositionPeriodic:
    case Effect::kPreslidingHysteresis: return std::nullopt;
  }
  return std::nullopt;
}

int drift_count(const ModelParams& p) {
  int n = 0;
  while (p.index("drift_" + std::to_string(n + 1)) >= 0) ++n;
  return n;
}

ModelParams at_strength(ModelParams p, Effect e, double s) {
  switch (e) {
    case Effect::kDrift: {
      const int n = drift_count(p);
      for (int j = 0; j < n; ++j) p.set_value("drift_" + std::to_string(j + 1), s * (n > 1 ? j / (n - 1.0) - 0.5 : 0.0));
      break;
    }
    case Effect::kRateState:
      p.set_value("rs_a", s);
      p.set_value("rs_b", s);
      break;
    case Effect::kDirectionAsymmetry:
      p.set_value("asym_levels", s);
      p.set_value("asym_viscous", 0.0);
      break;
    default: p.set_value(axis_of(e)->parameter, s);
  }
  return p;
}

// A typical strength to start from: the parameter's own scale (for drift, the
// drift functions' scale).
double reference_strength(const ModelParams& extended, Effect e) {
  const std::string name = e == Effect::kDrift ? "drift_1" : axis_of(e)->parameter;
  return std::fabs(extended.specs[static_cast<std::size_t>(extended.index(name))].scale);
}

}  // namespace

std::vector<int> free_columns(const ModelParams& p) {
  std::vector<int> cols;
  for (std::size_t k = 0; k < p.specs.size(); ++k) {
    if (!p.specs[k].fixed) cols.push_back(static_cast<int>(k));
  }
  return cols;
}

VisibleRows visible_rows(const ModelData& data, const FitResult& current, const std::vector<double>& current_model,
                         const std::vector<char>& in_fit, const std::vector<char>& heldout) {
  VisibleRows rows;
  std::size_t n_heldout = 0;
  rows.fit = every_kth(in_fit, rows.n_fit);
  rows.heldout = every_kth(heldout, n_heldout);
  rows.sigma_fit = rms_at(data.series.force_n, current_model, rows.fit);
  rows.sigma_heldout = rms_at(data.series.force_n, current_model, rows.heldout);
  rows.n_effective = current.n_effective > 0 ? current.n_effective : static_cast<double>(rows.n_fit);
  return rows;
}

double visible_strength_z(const Eigen::VectorXd& r_fit, const VisibleRows& rows) {
  if (r_fit.size() == 0 || !(rows.sigma_fit > 0)) return std::numeric_limits<double>::quiet_NaN();
  const double power = r_fit.squaredNorm() / static_cast<double>(r_fit.size());
  return std::sqrt(rows.n_effective * power) / rows.sigma_fit;
}

double normal_quantile(double p) {
  double lo = -40, hi = 40;  // P(N < z) = erfc(-z / sqrt 2) / 2 grows with z: bisection to the last bit
  for (int i = 0; i < 200 && lo < hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid == lo || mid == hi) break;
    (0.5 * std::erfc(-mid / std::numbers::sqrt2) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

bool strength_is_linear(Effect effect) {
  switch (effect) {
    case Effect::kDwellStiction:
    case Effect::kVelocityStrengthening:
    case Effect::kLoadDependence:
    case Effect::kDirectionAsymmetry:
    case Effect::kTiltOffset: return true;
    default: return false;
  }
}

ModelParams with_strength(const ModelParams& current, Effect effect, const ModelData& data, double s) {
  return at_strength(with_effect(current, effect, data), effect, s);
}

namespace {

// The effects whose figure the fitted error bounds (raise_to_fitted_error).
bool fitted_error_bounds_figure(Effect effect) { return strength_is_linear(effect) || effect == Effect::kRateState; }

}  // namespace

void raise_to_fitted_error(DetectableStrength& figure, Effect effect, const std::vector<ParamEstimate>& trial_parameters,
                           const DetectabilityCriteria& criteria) {
  if (!fitted_error_bounds_figure(effect) || !std::isfinite(figure.value)) return;
  for (const ParamEstimate& e : trial_parameters) {
    if (e.name != figure.parameter || e.fixed || !(std::isfinite(e.std_error) && e.std_error > 0)) continue;
    const double needed = (criteria.min_strength_z + normal_quantile(criteria.detection_probability)) * e.std_error;
    if (needed > figure.value) {
      figure.value = needed;
      figure.from_fitted_error = true;
    }
  }
}

DetectabilityBasis::DetectabilityBasis(const ModelData& data, const FitResult& current,
                                       const std::vector<double>& current_model, const std::vector<char>& in_fit,
                                       const std::vector<char>& heldout)
    : data_(data), current_(current), current_model_(current_model),
      rows_(visible_rows(data, current, current_model, in_fit, heldout)) {
  if (rows_.fit.empty() || rows_.heldout.empty()) return;
  const std::vector<int> cols = free_columns(current.params);
  jacobian_fit_ = model_jacobian(data, current.params, current.params.theta, cols, rows_.fit);
  jacobian_heldout_ = model_jacobian(data, current.params, current.params.theta, cols, rows_.heldout);
  qr_fit_.compute(jacobian_fit_);
}

DetectabilityBasis::Visible DetectabilityBasis::visible(const ModelParams& extended, Effect effect, double s) const {
  const std::vector<double> model = simulate(data_, at_strength(extended, effect, s));
  const auto change = [&](const std::vector<std::size_t>& rows) {
    Eigen::VectorXd d(static_cast<Eigen::Index>(rows.size()));
    for (std::size_t r = 0; r < rows.size(); ++r) d[static_cast<Eigen::Index>(r)] = model[rows[r]] - current_model_[rows[r]];
    return d;
  };
  const Eigen::VectorXd df = change(rows_.fit);
  Eigen::VectorXd rf = df;
  Eigen::VectorXd rh = change(rows_.heldout);
  if (!rf.allFinite() || !rh.allFinite()) return {};
  // What a refit of the model's own parameters takes up (fitted on the fit
  // rows, carried to the held-out rows as the refitted model would be).
  if (jacobian_fit_.cols() > 0) {
    const Eigen::VectorXd beta = qr_fit_.solve(rf);
    rf -= jacobian_fit_ * beta;
    rh -= jacobian_heldout_ * beta;
  }
  Visible v;
  v.power_fit = rf.squaredNorm() / static_cast<double>(rf.size());
  v.power_heldout = rh.squaredNorm() / static_cast<double>(rh.size());
  const double norm = df.norm();
  if (norm > 0) {
    const double m = static_cast<double>(rf.size());
    // Over m subsampled rows of n_fit: sum d r / (sigma |d|) is the t of m
    // independent rows; the fit's n_eff of its n_fit sets the real count.
    v.score_t = std::fabs(df.dot(rf)) / (rows_.sigma_fit * norm) * std::sqrt(std::min(rows_.n_effective, static_cast<double>(rows_.n_fit)) / m);
  }
  return v;
}

std::optional<DetectableStrength> DetectabilityBasis::minimum_detectable_strength(
    Effect effect, const DetectabilityCriteria& criteria) const {
  const auto axis = axis_of(effect);
  if (!axis || rows_.fit.empty() || rows_.heldout.empty() || !(rows_.sigma_heldout > 0) || !(rows_.sigma_fit > 0)) return std::nullopt;
  const double sigma_fit = rows_.sigma_fit, sigma_heldout = rows_.sigma_heldout;
  const ModelParams extended = with_effect(current_.params, effect, data_);
  int k_effect = 0;
  for (const auto& spec : extended.specs) k_effect += spec.effect == effect && !spec.fixed;
  // The visible power each gate needs (see the header); the t statistics'
  // expected values must clear their thresholds by the margin.
  const double margin = normal_quantile(criteria.detection_probability);
  const double strength_z = criteria.min_strength_z + margin, score_t = criteria.min_score_t + margin;
  const double g = criteria.min_heldout_gain;
  const double need_heldout = sigma_heldout * sigma_heldout * (1.0 / ((1.0 - g) * (1.0 - g)) - 1.0);
  const double need_aicc = sigma_fit * sigma_fit *
                           std::expm1((2.0 * k_effect - criteria.max_delta_aicc) / static_cast<double>(rows_.n_fit));
  const double need_strength = sigma_fit * sigma_fit * strength_z * strength_z / rows_.n_effective;
  const double need_fit = std::max(need_aicc, need_strength);
  const double reference = reference_strength(extended, effect);
  DetectableStrength out;
  out.parameter = axis->parameter;
  const std::string unit_of = effect == Effect::kDrift ? "drift_1" : axis->parameter;
  out.unit = extended.specs[static_cast<std::size_t>(extended.index(unit_of))].unit;
  out.axis = axis->words;
  out.detection_probability = criteria.detection_probability;
  out.searched_up_to = 1e4 * reference;
  out.value = std::numeric_limits<double>::infinity();
  // Secant steps on s: for a linear effect the power grows as s^2, so one
  // step lands on the threshold; nonlinear ones take a few.
  double s = reference;
  for (int step = 0; step < 12; ++step) {
    const Visible v = visible(extended, effect, s);
    // The score t grows as s, the powers as s^2: its ratio squared.
    const double score_ratio = v.score_t > 0 ? (score_t / v.score_t) * (score_t / v.score_t) : HUGE_VAL;
    const double ratio = std::max({v.power_heldout > 0 ? need_heldout / v.power_heldout : HUGE_VAL,
                                   v.power_fit > 0 ? need_fit / v.power_fit : HUGE_VAL, score_ratio});
    if (!std::isfinite(ratio)) break;  // nothing of it survives the refit: not identifiable
    if (std::fabs(ratio - 1.0) < 0.02) {
      out.value = s;
      break;
    }
    s *= std::clamp(std::sqrt(ratio), 0.01, 100.0);
    if (s > out.searched_up_to) break;
    if (step == 11) out.value = s;  // the last step's estimate
  }
  return out;
}

}  // namespace tribo::analysis
