#include "analysis/effects/regression.h"

#include <algorithm>
#include <cmath>

#include "analysis/models/chunked_qr.h"
#include "analysis/models/model_fit.h"

namespace tribo::analysis {

Regression regress(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  Regression r;
  const Eigen::Index n = X.rows(), k = X.cols();
  if (n < k + 3) return r;
  // [X y] reduced to its triangle in one pass over X, in chunks (no copy of
  // X: the score test's is the widest array of its phase, one per core);
  // X b = y in least squares is R b = Q1^T y.
  const Eigen::MatrixXd triangle = chunked_triangle(X, y);
  const Eigen::MatrixXd factor = triangle.topLeftCorner(k, k);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(factor);
  if (qr.rank() < k) return r;
  r.coef = qr.solve(triangle.col(k).head(k).eval());
  const Eigen::VectorXd e = y - X * r.coef;
  r.n_effective = effective_sample_count(e.data(), static_cast<std::size_t>(e.size()));
  const double s2 = e.squaredNorm() / static_cast<double>(n - k);
  const double inflation = static_cast<double>(n) / std::max(r.n_effective, 1.0);
  const Eigen::MatrixXd xtx = factor.transpose() * factor;
  const Eigen::MatrixXd cov = s2 * inflation * xtx.inverse();
  r.std_error = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double mean = y.mean();
  const double tss = (y.array() - mean).square().sum();
  r.r_squared = tss > 0 ? 1.0 - e.squaredNorm() / tss : 0.0;
  r.ok = true;
  return r;
}

void Design::add_row(std::initializer_list<double> x, double target) {
  if (columns.empty()) columns.resize(x.size());
  std::size_t j = 0;
  for (double v : x) columns[j++].push_back(v);
  y.push_back(target);
}

void Design::reserve(std::size_t width, std::size_t rows) {
  if (columns.empty()) columns.resize(width);
  for (auto& c : columns) c.reserve(rows);
  y.reserve(rows);
}

Regression Design::fit() const {
  const auto n = static_cast<Eigen::Index>(y.size());
  Eigen::MatrixXd X(n, static_cast<Eigen::Index>(columns.size()));
  for (std::size_t j = 0; j < columns.size(); ++j) {
    for (Eigen::Index i = 0; i < n; ++i) X(i, static_cast<Eigen::Index>(j)) = columns[j][static_cast<std::size_t>(i)];
  }
  return regress(X, Eigen::Map<const Eigen::VectorXd>(y.data(), n));
}

}  // namespace tribo::analysis
