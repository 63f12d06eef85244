// Coloured noise for the simulated instrument: Gauss-Markov processes,
// discretised exactly for any step, so their statistics do not depend on the
// loop rate. Each process owns its NoiseSource (one generator per source) and
// starts from a draw of its stationary distribution.
//
// First order (Ornstein-Uhlenbeck), RMS sigma, correlation time tau:
//   dn = -n / tau dt + sigma sqrt(2 / tau) dW
//   n(t + h) = a n(t) + sigma sqrt(1 - a^2) w,   a = exp(-h / tau)
//
// Second order, critically damped at omega = 2 pi corner_hz, RMS sigma:
//   n'' + 2 omega n' + omega^2 n = sqrt(q) W',   q = 4 omega^3 sigma^2
// Its power spectrum falls as f^-4 above the corner, so unlike white or
// first-order noise it has almost no power at the loop rate: a position
// sensor's low-frequency wander that a fast loop follows without dithering
// the contact. The exact update is (n, n')(t + h) = Phi (n, n')(t) + L w with
// Phi = exp(A h) and L L^T the integrated covariance over h.
#pragma once

#include <cstdint>

#include "sim/noise_source.h"

namespace tribo::sim {

class FirstOrderGaussMarkov {
 public:
  FirstOrderGaussMarkov(double rms, double correlation_time_s, std::uint64_t seed);
  double value() const { return value_; }
  double advance(double dt_s);

 private:
  double rms_;
  double correlation_time_s_;
  NoiseSource noise_;
  double value_ = 0;
  double cached_dt_s_ = -1, decay_ = 0, kick_ = 0;
};

class SecondOrderGaussMarkov {
 public:
  SecondOrderGaussMarkov(double rms, double corner_hz, std::uint64_t seed);
  double value() const { return value_; }
  double advance(double dt_s);

 private:
  void prepare(double dt_s);

  double rms_;
  double omega_;
  NoiseSource noise_;
  double value_ = 0, rate_ = 0;
  double cached_dt_s_ = -1;
  double phi_[2][2] = {};
  double chol_[2][2] = {};  // lower triangular
};

}  // namespace tribo::sim
