// ln(1 + d) for |d| <= kLogNearOneReach without a call to log: the Taylor
// series to d^9, d - d^2/2 + d^3/3 - ... + d^9/9, summed in Estrin's scheme
// (pairs, then pairs of pairs: a short dependency chain). The first term
// left out is at most (1/32)^10 / 10 = 9e-18, under a tenth of the last bit
// of ln(1 + d) + L for any L >= 1e-1 ... and 20 times below the double
// precision of d itself at the reach. The slip-rate solve
// (sim/friction_effects.cc) takes ln(1 + w / V*) at a slip rate w near one
// whose logarithm it has: ln(V* + w) - ln(V* + w_ref) = ln(1 + d),
// d = (w - w_ref) / (V* + w_ref): this and an addition in place of glibc's
// log1p (34 ns of latency on the 2-core VM, log 19 ns).
// tests/sim/friction_effects_test.cc holds it against std::log1p over the reach.
#pragma once

namespace tribo::sim {

inline constexpr double kLogNearOneReach = 1.0 / 32;

inline double log_near_one(double d) {
  const double d2 = d * d, d4 = d2 * d2;
  const double p0 = -1.0 / 2 + d * (1.0 / 3), p1 = -1.0 / 4 + d * (1.0 / 5);
  const double p2 = -1.0 / 6 + d * (1.0 / 7), p3 = -1.0 / 8 + d * (1.0 / 9);
  return d + d2 * ((p0 + d2 * p1) + d4 * (p2 + d2 * p3));  // d + d^2 (-1/2 + d/3 - ...)
}

}  // namespace tribo::sim
