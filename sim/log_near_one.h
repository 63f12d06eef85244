// ln(1 + d) for |d| <= kLogNearOneReach without a call to log: the Taylor
// series to d^9, d - d^2/2 + d^3/3 - ... + d^9/9, summed in Estrin's scheme
// (pairs, then pairs of pairs: a short dependency chain). The first term
// left out is at most (1/32)^10 / 10 = 9e-17 absolute (it falls as |d|^10):
// below the last bit of any logarithm above 0.7 that it is added to, and a
// millionth of what the solve's residual asks of L. The slip-rate solve (sim/friction_effects.cc) takes
// ln(1 + w / V*) at slip rates w near one whose logarithm it has taken:
// ln(V* + w) - ln(V* + w_ref) = ln(1 + d), d = (w - w_ref) / (V* + w_ref),
// with this and an addition in place of a call (glibc's log took 19-35 ns of
// latency on the 2-core VM, this 16-20 ns, measured under load).
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
