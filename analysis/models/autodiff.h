// Forward-mode automatic differentiation for the model Jacobian: Eigen's
// AutoDiffScalar. Exact derivatives matter here: the parameters span twelve
// decades (sigma0 ~ 1e9 N/m, vs ~ 1e-6 m/s), where finite-difference steps
// are useless. Fixed-size derivative vectors (the next even width, padded
// with zeros) are two to three times faster than dynamic ones; the dynamic
// type remains for callers that want an arbitrary count.
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>

namespace tribo::analysis {

inline constexpr int kMaxFreeParams = 32;
using DerivativeVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxFreeParams, 1>;
using Dual = Eigen::AutoDiffScalar<DerivativeVector>;

template <int N>
using FixedDual = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;

inline double value_of(double x) { return x; }
template <class Derivatives>
double value_of(const Eigen::AutoDiffScalar<Derivatives>& x) {
  return x.value();
}

}  // namespace tribo::analysis
