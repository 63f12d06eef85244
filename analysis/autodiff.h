// Forward-mode automatic differentiation for the model Jacobian: Eigen's
// AutoDiffScalar with a derivative vector of bounded size (no heap use).
// Exact derivatives matter here: the parameters span twelve decades (sigma0
// ~ 1e9 N/m, vs ~ 1e-6 m/s), where finite-difference steps are useless.
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>

namespace tribo::analysis {

inline constexpr int kMaxFreeParams = 32;
using DerivativeVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxFreeParams, 1>;
using Dual = Eigen::AutoDiffScalar<DerivativeVector>;

inline double value_of(double x) { return x; }
inline double value_of(const Dual& x) { return x.value(); }

}  // namespace tribo::analysis
