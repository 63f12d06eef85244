#include "sim/gauss_markov.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tribo::sim {

FirstOrderGaussMarkov::FirstOrderGaussMarkov(double rms, double correlation_time_s,
                                             std::uint64_t seed)
    : rms_(rms), correlation_time_s_(correlation_time_s), noise_(seed) {
  if (rms_ > 0) value_ = rms_ * noise_.gaussian();
}

double FirstOrderGaussMarkov::advance(double dt_s) {
  if (!(rms_ > 0) || !(dt_s > 0)) return value_;
  if (dt_s != cached_dt_s_) {
    cached_dt_s_ = dt_s;
    decay_ = std::exp(-dt_s / correlation_time_s_);
    kick_ = rms_ * std::sqrt(-std::expm1(-2.0 * dt_s / correlation_time_s_));
  }
  value_ = decay_ * value_ + kick_ * noise_.gaussian();
  return value_;
}

namespace {

// I_n = integral_0^h s^n exp(-a s) ds = n! / a^(n+1) (1 - exp(-x) sum_{k<=n} x^k / k!),
// x = a h. For small x the bracket is evaluated as exp(-x) sum_{k>n} x^k / k!
// (no cancellation).
double exponential_moment(int n, double a, double h) {
  const double x = a * h;
  double bracket;
  if (x < 1.0) {
    double term = 1.0, tail = 0.0;
    for (int k = 1; k <= n; ++k) term *= x / k;  // x^n / n!
    for (int k = n + 1; k < 60; ++k) {
      term *= x / k;
      tail += term;
      if (term < 1e-18 * tail) break;
    }
    bracket = std::exp(-x) * tail;
  } else {
    double head = 0.0, term = 1.0;
    for (int k = 0; k <= n; ++k) {
      if (k > 0) term *= x / k;
      head += term;
    }
    bracket = 1.0 - std::exp(-x) * head;
  }
  double factorial = 1.0;
  for (int k = 2; k <= n; ++k) factorial *= k;
  return factorial / std::pow(a, n + 1) * bracket;
}

}  // namespace

SecondOrderGaussMarkov::SecondOrderGaussMarkov(double rms, double corner_hz, std::uint64_t seed)
    : rms_(rms), omega_(2.0 * std::numbers::pi * corner_hz), noise_(seed) {
  if (rms_ > 0) {
    value_ = rms_ * noise_.gaussian();           // stationary: var(n) = sigma^2,
    rate_ = omega_ * rms_ * noise_.gaussian();   // var(n') = omega^2 sigma^2, uncorrelated
  }
}

void SecondOrderGaussMarkov::prepare(double h) {
  cached_dt_s_ = h;
  const double w = omega_, e = std::exp(-w * h);
  phi_[0][0] = e * (1 + w * h);
  phi_[0][1] = e * h;
  phi_[1][0] = -e * w * w * h;
  phi_[1][1] = e * (1 - w * h);
  // exp(A s) b = exp(-w s) (s, 1 - w s): Q = q integral of its outer product.
  const double q = 4 * w * w * w * rms_ * rms_;
  const double i0 = exponential_moment(0, 2 * w, h);
  const double i1 = exponential_moment(1, 2 * w, h);
  const double i2 = exponential_moment(2, 2 * w, h);
  const double q11 = q * i2, q12 = q * (i1 - w * i2), q22 = q * (i0 - 2 * w * i1 + w * w * i2);
  chol_[0][0] = std::sqrt(q11);
  chol_[1][0] = q12 / chol_[0][0];
  chol_[1][1] = std::sqrt(std::max(0.0, q22 - chol_[1][0] * chol_[1][0]));
}

double SecondOrderGaussMarkov::advance(double dt_s) {
  if (!(rms_ > 0) || !(dt_s > 0)) return value_;
  if (dt_s != cached_dt_s_) prepare(dt_s);
  const double w1 = noise_.gaussian(), w2 = noise_.gaussian();
  const double n = phi_[0][0] * value_ + phi_[0][1] * rate_ + chol_[0][0] * w1;
  const double r = phi_[1][0] * value_ + phi_[1][1] * rate_ + chol_[1][0] * w1 + chol_[1][1] * w2;
  value_ = n;
  rate_ = r;
  return value_;
}

}  // namespace tribo::sim
