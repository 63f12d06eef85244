// Ordinary least squares for residual signatures, with standard errors that
// respect autocorrelated rows: a time-ordered residual is far from
// independent samples, so the OLS errors are inflated by sqrt(n / n_eff)
// (n_eff from the lag-1 autocorrelation of the regression residual).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>

namespace tribo::analysis {

struct Regression {
  Eigen::VectorXd coef;
  Eigen::VectorXd std_error;
  double r_squared = 0;     // of the full model against the mean
  double n_effective = 0;
  bool ok = false;

  double t(int j) const { return std_error[j] > 0 ? coef[j] / std_error[j] : 0.0; }
};

// rows of X and y in time order; at least cols + 3 rows, else ok = false.
// X is read, not copied (the score test's Jacobian is the widest array of
// its phase).
Regression regress(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);

// Builds X and y from per-row callbacks over the selected sample indices.
struct Design {
  std::vector<std::vector<double>> columns;
  std::vector<double> y;
  void add_row(std::initializer_list<double> x, double target);
  // Room for `rows` rows of `width` regressors (no regrowth while rows are added).
  void reserve(std::size_t width, std::size_t rows);
  Regression fit() const;
  std::size_t rows() const { return y.size(); }
};

}  // namespace tribo::analysis
