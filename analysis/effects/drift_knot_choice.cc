#include "analysis/effects/drift_knot_choice.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace tribo::analysis {

namespace {

// Least-squares sufficient statistics of the residual on the drift basis.
struct Moments {
  Eigen::MatrixXd gram;   // sum x x^T
  Eigen::VectorXd cross;  // sum x r
  double rr = 0;          // sum r^2
  std::size_t n = 0;
  explicit Moments(int functions) : gram(Eigen::MatrixXd::Zero(functions, functions)), cross(Eigen::VectorXd::Zero(functions)) {}
};

// The left-out passes' mean squared prediction error, and its standard error
// from the spread of the per-pass means.
struct CrossValidation {
  double ms = HUGE_VAL, se = 0;
};

CrossValidation cross_validate(const std::map<int, Moments>& folds, const Moments& total) {
  double sum = 0;
  std::size_t count = 0;
  std::vector<double> per_pass;
  const double ridge = 1e-9 * std::max(total.gram.diagonal().maxCoeff(), 1e-300);
  for (const auto& [pass, f] : folds) {
    Eigen::MatrixXd a = total.gram - f.gram;
    a.diagonal().array() += ridge;
    const Eigen::VectorXd beta = a.ldlt().solve(total.cross - f.cross);
    const double err = f.rr - 2 * beta.dot(f.cross) + beta.dot(f.gram * beta);
    sum += err;
    count += f.n;
    if (f.n > 0) per_pass.push_back(err / static_cast<double>(f.n));
  }
  CrossValidation cv;
  if (count == 0 || per_pass.size() < 2) return cv;
  cv.ms = sum / static_cast<double>(count);
  double mean = 0, var = 0;
  for (double e : per_pass) mean += e / static_cast<double>(per_pass.size());
  for (double e : per_pass) var += (e - mean) * (e - mean) / static_cast<double>(per_pass.size() - 1);
  cv.se = std::sqrt(var / static_cast<double>(per_pass.size()));
  return cv;
}

}  // namespace

DriftKnotChoice choose_drift_intervals(ModelData& data, const std::vector<double>& residual,
                                       const std::vector<char>& in_fit) {
  DriftKnotChoice choice;
  choice.default_intervals = data.drift_intervals();
  choice.intervals = choice.default_intervals;
  const MotionSegmentation& m = data.motion;
  std::vector<CrossValidation> tried;
  for (int k = 3; k <= choice.default_intervals; ++k) {
    data.set_drift_intervals(k);
    const int functions = data.drift_functions;
    Moments total(functions);
    std::map<int, Moments> folds;
    std::vector<double> x(static_cast<std::size_t>(functions));
    // A pass's samples are consecutive: its fold is looked up once.
    int fold_pass = -1;
    Moments* fold = nullptr;
    for (std::size_t i = 0; i < residual.size(); ++i) {
      if (!in_fit[i] || !std::isfinite(residual[i])) continue;
      // Only the four functions that are not zero at i enter the sums.
      const int first = data.drift_basis_at(i, x.data());
      const int end = std::min(first + 4, functions);
      if (m.pass_of[i] != fold_pass) {
        fold_pass = m.pass_of[i];
        fold = fold_pass >= 0 ? &folds.try_emplace(fold_pass, functions).first->second : nullptr;
      }
      for (int a = first; a < end; ++a) {
        if (x[a] == 0.0) continue;
        for (int b = first; b < end; ++b) {
          if (x[b] == 0.0) continue;
          total.gram(a, b) += x[a] * x[b];
          if (fold) fold->gram(a, b) += x[a] * x[b];
        }
        total.cross[a] += x[a] * residual[i];
        if (fold) fold->cross[a] += x[a] * residual[i];
      }
      total.rr += residual[i] * residual[i];
      ++total.n;
      if (fold) {
        fold->rr += residual[i] * residual[i];
        ++fold->n;
      }
    }
    if (folds.size() < 2) break;
    const CrossValidation cv = cross_validate(folds, total);
    choice.cv_rms.emplace_back(k, std::sqrt(cv.ms));
    tried.push_back(cv);
  }
  // The one-standard-error rule (Hastie, Tibshirani and Friedman, The Elements
  // of Statistical Learning, 2nd ed., sec. 7.10): the fewest intervals whose
  // error lies within one standard error of the least; the least alone picks
  // among counts that differ by noise (a straight drift: 3 to 7 intervals
  // within 0.4 %, tests/analysis/drift_knot_choice_test.cc).
  std::size_t best = 0;
  for (std::size_t j = 1; j < tried.size(); ++j) {
    if (tried[j].ms < tried[best].ms) best = j;
  }
  for (std::size_t j = 0; j < tried.size(); ++j) {
    if (tried[j].ms <= tried[best].ms + tried[best].se) {
      choice.intervals = choice.cv_rms[j].first;
      break;
    }
  }
  data.set_drift_intervals(choice.intervals);
  return choice;
}

}  // namespace tribo::analysis
