// Steady-state friction curves with one nonlinear scale, fitted robustly where
// the dissertation struggled (§6.3.2: sensitive to the initial guess, points
// dropped by hand at both ends):
//
//   LuGre steady state (dissertation §2, eqs. 9-13):
//     F(v) = sgn(v) (Fc + (Fs - Fc) exp(-(|v|/vs)^delta)) + Fv v [+ offset]
//   eq. 44 (friction coefficient against the Gumbel number x):
//     mu(x) = p1 + p2 exp(-p3 x) + p4 x
//
// Both are linear in all parameters but one scale (vs, 1/p3). That scale is
// found globally: a log-spaced grid over the whole data range with the linear
// parameters solved exactly at each grid point (variable projection), then a
// golden-section refinement. No initial guess is needed. Points are weighted,
// not dropped: the given weights (e.g. 1/variance) times robust Huber weights
// from iterative reweighting, so outliers at the ends lose influence by
// themselves. Standard errors from the weighted Jacobian at the solution.
#pragma once

#include <string>
#include <vector>

namespace tribo::analysis {

struct CurvePoint {
  double x = 0;       // velocity (signed, m/s) or Gumbel number
  double y = 0;       // friction force, or mu
  double weight = 1;  // e.g. 1 / variance of y
};

struct CurveFit {
  std::vector<std::string> names;
  std::vector<double> values;
  std::vector<double> std_errors;
  std::vector<double> robust_weights;  // per point, 1 = full weight
  double rms = 0;                      // weighted RMS residual
  bool scale_determined = true;        // the nonlinear scale lies inside the data range
  std::vector<std::string> warnings;

  double value(const std::string& name) const;
};

// LuGre steady state; names Fc, Fs, vs, Fv [, offset]. Needs points at both
// low and high speed for vs to be determined.
CurveFit fit_stribeck_curve(const std::vector<CurvePoint>& points, double exponent, bool fit_offset);

// eq. 44; names p1, p2, p3, p4.
CurveFit fit_eq44(const std::vector<CurvePoint>& points);

double stribeck_curve(const CurveFit& fit, double velocity, double exponent);
double eq44_curve(const CurveFit& fit, double x);

}  // namespace tribo::analysis
