#include "analysis/effects/regression.h"

#include <algorithm>
#include <cmath>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {

namespace {

// ColPivHouseholderQR<MatrixXd>(X) in X's own storage: compute() copies the
// matrix and factorises the copy in place (computeInPlace), so this is the
// same factorisation, bit for bit, without the copy. release() hands the
// storage back (it then holds the factor).
class QRInPlace : public Eigen::ColPivHouseholderQR<Eigen::MatrixXd> {
 public:
  explicit QRInPlace(Eigen::MatrixXd& X) {
    m_qr.swap(X);
    computeInPlace();
  }
  void release(Eigen::MatrixXd& X) { m_qr.swap(X); }
};

}  // namespace

Regression regress_in_place(Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                            const std::function<void(Eigen::MatrixXd&)>& refill) {
  Regression r;
  const Eigen::Index n = X.rows(), k = X.cols();
  if (n < k + 3) return r;
  // X^T X before the factorisation takes X's storage (the same product,
  // evaluated the same way, as inverted below).
  const Eigen::MatrixXd xtx = X.transpose() * X;
  QRInPlace qr(X);
  if (qr.rank() < k) {
    qr.release(X);
    return r;
  }
  r.coef = qr.solve(y);
  qr.release(X);
  refill(X);
  const Eigen::VectorXd e = y - X * r.coef;
  r.n_effective = effective_sample_count(e.data(), static_cast<std::size_t>(e.size()));
  const double s2 = e.squaredNorm() / static_cast<double>(n - k);
  const double inflation = static_cast<double>(n) / std::max(r.n_effective, 1.0);
  const Eigen::MatrixXd cov = s2 * inflation * xtx.inverse();
  r.std_error = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  const double mean = y.mean();
  const double tss = (y.array() - mean).square().sum();
  r.r_squared = tss > 0 ? 1.0 - e.squaredNorm() / tss : 0.0;
  r.ok = true;
  return r;
}

Regression regress(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  Eigen::MatrixXd work = X;
  return regress_in_place(work, y, [&](Eigen::MatrixXd& out) { out = X; });
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
  auto fill = [&](Eigen::MatrixXd& X) {
    X.resize(n, static_cast<Eigen::Index>(columns.size()));
    for (std::size_t j = 0; j < columns.size(); ++j) {
      for (Eigen::Index i = 0; i < n; ++i) X(i, static_cast<Eigen::Index>(j)) = columns[j][static_cast<std::size_t>(i)];
    }
  };
  Eigen::MatrixXd X;
  fill(X);
  return regress_in_place(X, Eigen::Map<const Eigen::VectorXd>(y.data(), n), fill);
}

}  // namespace tribo::analysis
