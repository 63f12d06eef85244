#include "analysis/models/stribeck_fit.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include <Eigen/Dense>

namespace tribo::analysis {

namespace {

// y = sum_j a_j phi_j(x, c): phi fills one row of basis values.
using Basis = std::function<void(double x, double c, double* phi)>;

struct Projection {
  Eigen::VectorXd a;
  double cost = 0;
};

Projection project(const std::vector<CurvePoint>& pts, const std::vector<double>& w, int m, const Basis& basis,
                   double c) {
  const auto n = static_cast<Eigen::Index>(pts.size());
  Eigen::MatrixXd A(n, m);
  Eigen::VectorXd b(n);
  std::vector<double> phi(static_cast<std::size_t>(m));
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& p = pts[static_cast<std::size_t>(i)];
    const double sw = std::sqrt(w[static_cast<std::size_t>(i)]);
    basis(p.x, c, phi.data());
    for (int j = 0; j < m; ++j) A(i, j) = sw * phi[static_cast<std::size_t>(j)];
    b[i] = sw * p.y;
  }
  Projection out;
  out.a = A.colPivHouseholderQr().solve(b);
  out.cost = (A * out.a - b).squaredNorm();
  return out;
}

double median_abs(std::vector<double> v) {
  for (double& x : v) x = std::fabs(x);
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double residual(const CurvePoint& p, const Eigen::VectorXd& a, int m, const Basis& basis, double c) {
  std::vector<double> phi(static_cast<std::size_t>(m));
  basis(p.x, c, phi.data());
  double y = 0;
  for (int j = 0; j < m; ++j) y += a[j] * phi[static_cast<std::size_t>(j)];
  return p.y - y;
}

// Global search for the scale c on a log grid, then golden section in log c.
double best_scale(const std::vector<CurvePoint>& pts, const std::vector<double>& w, int m, const Basis& basis,
                  double c_lo, double c_hi, bool& at_edge) {
  constexpr int kGrid = 80;
  const double l0 = std::log(c_lo), l1 = std::log(c_hi);
  int best = 0;
  double best_cost = HUGE_VAL;
  for (int g = 0; g < kGrid; ++g) {
    const double cost = project(pts, w, m, basis, std::exp(l0 + (l1 - l0) * g / (kGrid - 1))).cost;
    if (cost < best_cost) {
      best_cost = cost;
      best = g;
    }
  }
  at_edge = best <= 1 || best >= kGrid - 2;
  double lo = l0 + (l1 - l0) * std::max(best - 1, 0) / (kGrid - 1);
  double hi = l0 + (l1 - l0) * std::min(best + 1, kGrid - 1) / (kGrid - 1);
  const double r = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = hi - r * (hi - lo), x2 = lo + r * (hi - lo);
  double f1 = project(pts, w, m, basis, std::exp(x1)).cost, f2 = project(pts, w, m, basis, std::exp(x2)).cost;
  for (int it = 0; it < 60; ++it) {
    if (f1 < f2) {
      hi = x2; x2 = x1; f2 = f1; x1 = hi - r * (hi - lo);
      f1 = project(pts, w, m, basis, std::exp(x1)).cost;
    } else {
      lo = x1; x1 = x2; f1 = f2; x2 = lo + r * (hi - lo);
      f2 = project(pts, w, m, basis, std::exp(x2)).cost;
    }
  }
  return std::exp(0.5 * (lo + hi));
}

// scale_value(c) gives the reported nonlinear parameter (vs = c, p3 = 1/c).
CurveFit fit_one_scale(const std::vector<CurvePoint>& pts, int m, const Basis& basis, double c_lo, double c_hi,
                       std::vector<std::string> names, int scale_position) {
  CurveFit fit;
  fit.names = std::move(names);
  const std::size_t n = pts.size();
  const int p = m + 1;
  if (n <= static_cast<std::size_t>(p)) throw std::invalid_argument("curve fit: need more points than parameters");
  std::vector<double> robust(n, 1.0), w(n);
  double c = 0;
  bool at_edge = false;
  Projection proj;
  for (int iteration = 0; iteration < 8; ++iteration) {
    for (std::size_t i = 0; i < n; ++i) w[i] = pts[i].weight * robust[i];
    c = best_scale(pts, w, m, basis, c_lo, c_hi, at_edge);
    proj = project(pts, w, m, basis, c);
    // Huber weights on standardised residuals (MAD scale).
    std::vector<double> u(n);
    for (std::size_t i = 0; i < n; ++i) u[i] = std::sqrt(pts[i].weight) * residual(pts[i], proj.a, m, basis, c);
    const double sigma = 1.4826 * median_abs(u);
    if (!(sigma > 0)) break;
    double change = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double k = 1.345 * sigma;
      const double next = std::fabs(u[i]) <= k ? 1.0 : k / std::fabs(u[i]);
      change = std::max(change, std::fabs(next - robust[i]));
      robust[i] = next;
    }
    if (change < 1e-3) break;
  }
  for (std::size_t i = 0; i < n; ++i) w[i] = pts[i].weight * robust[i];
  proj = project(pts, w, m, basis, c);

  // Jacobian in (a, ln c), weighted; covariance s^2 (J^T W J)^-1.
  Eigen::MatrixXd J(static_cast<Eigen::Index>(n), p);
  std::vector<double> phi(static_cast<std::size_t>(m)), phi_hi(static_cast<std::size_t>(m)), phi_lo(static_cast<std::size_t>(m));
  constexpr double eps = 1e-5;
  double wrss = 0, wsum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double sw = std::sqrt(w[i]);
    basis(pts[i].x, c, phi.data());
    basis(pts[i].x, c * std::exp(eps), phi_hi.data());
    basis(pts[i].x, c * std::exp(-eps), phi_lo.data());
    double dlnc = 0;
    for (int j = 0; j < m; ++j) {
      J(static_cast<Eigen::Index>(i), j) = sw * phi[static_cast<std::size_t>(j)];
      dlnc += proj.a[j] * (phi_hi[static_cast<std::size_t>(j)] - phi_lo[static_cast<std::size_t>(j)]) / (2 * eps);
    }
    J(static_cast<Eigen::Index>(i), m) = sw * dlnc;
    const double r = residual(pts[i], proj.a, m, basis, c);
    wrss += w[i] * r * r;
    wsum += w[i];
  }
  const double s2 = wrss / static_cast<double>(n - static_cast<std::size_t>(p));
  const Eigen::MatrixXd cov = s2 * (J.transpose() * J).completeOrthogonalDecomposition().pseudoInverse();
  fit.rms = std::sqrt(wrss / wsum);
  fit.robust_weights = robust;

  // Reported order: the linear parameters with the scale inserted at scale_position.
  std::vector<double> values, errors;
  for (int j = 0; j < m; ++j) {
    values.push_back(proj.a[j]);
    errors.push_back(std::sqrt(std::max(cov(j, j), 0.0)));
  }
  const double se_lnc = std::sqrt(std::max(cov(m, m), 0.0));
  fit.values = values;
  fit.std_errors = errors;
  fit.values.insert(fit.values.begin() + scale_position, c);
  fit.std_errors.insert(fit.std_errors.begin() + scale_position, c * se_lnc);
  // The scale means something only where its term's amplitude (the second
  // linear parameter: Fs - Fc, p2) is clearly non-zero.
  const bool amplitude_seen = std::fabs(proj.a[1]) > 2 * std::sqrt(std::max(cov(1, 1), 0.0));
  fit.scale_determined = !at_edge && se_lnc < 1.0 && amplitude_seen;
  if (!fit.scale_determined) {
    fit.warnings.push_back(fit.names[static_cast<std::size_t>(scale_position)] +
                           " is not determined: its term is not seen in the data, or the best value lies at the "
                           "edge of the data range, or it is uncertain by more than a factor e");
  }
  return fit;
}

void range_of(const std::vector<CurvePoint>& pts, bool absolute, double& lo, double& hi) {
  lo = HUGE_VAL;
  hi = 0;
  for (const auto& p : pts) {
    const double x = absolute ? std::fabs(p.x) : p.x;
    if (x > 0) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  }
  if (!(hi > 0)) throw std::invalid_argument("curve fit: no positive abscissa");
}

}  // namespace

double CurveFit::value(const std::string& name) const {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return values[i];
  }
  throw std::invalid_argument("no curve parameter " + name);
}

CurveFit fit_stribeck_curve(const std::vector<CurvePoint>& pts, double exponent, bool fit_offset) {
  double lo = 0, hi = 0;
  range_of(pts, true, lo, hi);
  const int m = fit_offset ? 4 : 3;
  Basis basis = [exponent, fit_offset](double v, double vs, double* phi) {
    const double s = v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
    phi[0] = s;
    phi[1] = s * std::exp(-std::pow(std::fabs(v) / vs, exponent));
    phi[2] = v;
    if (fit_offset) phi[3] = 1.0;
  };
  std::vector<std::string> names = {"Fc", "dF", "vs", "Fv"};
  if (fit_offset) names.push_back("offset");
  CurveFit fit = fit_one_scale(pts, m, basis, lo / 10, hi * 10, names, 2);
  // Report Fs = Fc + dF (its error from the covariance is not kept; dF's is a close bound).
  fit.names[1] = "Fs";
  fit.values[1] += fit.values[0];
  fit.std_errors[1] = std::hypot(fit.std_errors[1], fit.std_errors[0]);
  return fit;
}

CurveFit fit_eq44(const std::vector<CurvePoint>& pts) {
  double lo = 0, hi = 0;
  range_of(pts, false, lo, hi);
  Basis basis = [](double x, double c, double* phi) {
    phi[0] = 1.0;
    phi[1] = std::exp(-x / c);
    phi[2] = x;
  };
  CurveFit fit = fit_one_scale(pts, 3, basis, lo / 10, hi * 10, {"p1", "p2", "c", "p4"}, 2);
  // p3 = 1 / c; relative errors carry over.
  fit.names[2] = "p3";
  const double c = fit.values[2];
  fit.std_errors[2] = fit.std_errors[2] / (c * c);
  fit.values[2] = 1.0 / c;
  for (auto& w : fit.warnings) {
    if (w.rfind("c ", 0) == 0) w = "p3" + w.substr(1);
  }
  return fit;
}

double stribeck_curve(const CurveFit& fit, double v, double exponent) {
  const double s = v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
  double f = s * (fit.value("Fc") + (fit.value("Fs") - fit.value("Fc")) *
                                          std::exp(-std::pow(std::fabs(v) / fit.value("vs"), exponent))) +
             fit.value("Fv") * v;
  for (std::size_t i = 0; i < fit.names.size(); ++i) {
    if (fit.names[i] == "offset") f += fit.values[i];
  }
  return f;
}

double eq44_curve(const CurveFit& fit, double x) {
  return fit.value("p1") + fit.value("p2") * std::exp(-fit.value("p3") * x) + fit.value("p4") * x;
}

}  // namespace tribo::analysis
