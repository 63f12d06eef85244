// sin x for |x| <= pi/2 without a branch (the fitted contact's speed).
// The elasto-plastic blend (sim/lugre_friction.h) takes a sine whose argument
// pi (|z|/g - (1 + r)/2) / (1 - r) stays within [-pi/2, pi/2] and, on a
// sliding contact under the loop's dither, mostly within 0.6 of +pi/2,
// where glibc's sin takes its slower range (|x| > 0.855): 13 ns of latency
// against this polynomial's 8 (measured on the 2-core VM), and no
// data-dependent branch. The Taylor series of sin to x^21: the first term
// left out, (pi/2)^23 / 23!, is 1.3e-18, under a hundredth of the last bit of
// sin x near its peak; x + x^3 Q(x^2) with Q summed in Estrin's scheme (pairs,
// then pairs of pairs), a short dependency chain.
// tests/sim/lugre_friction_test.cc holds it within 3 units in the last place
// of std::sin over the whole interval.
#pragma once

namespace tribo::sim {

namespace quarter_sine_detail {

// (-1)^k / (2k + 1)!
constexpr double coefficient(int k) {
  double c = 1.0;
  for (int i = 2; i <= 2 * k + 1; ++i) c /= i;
  return k % 2 ? -c : c;
}

}  // namespace quarter_sine_detail

inline double sine_on_quarter(double x) {
  using quarter_sine_detail::coefficient;
  const double y = x * x, y2 = y * y, y4 = y2 * y2, y8 = y4 * y4;
  const double p0 = coefficient(1) + coefficient(2) * y, p1 = coefficient(3) + coefficient(4) * y;
  const double p2 = coefficient(5) + coefficient(6) * y, p3 = coefficient(7) + coefficient(8) * y;
  const double p4 = coefficient(9) + coefficient(10) * y;
  const double q0 = p0 + y2 * p1, q1 = p2 + y2 * p3;
  return x + (x * y) * ((q0 + y4 * q1) + y8 * p4);  // x + x^3 (-1/3! + x^2/5! - ...)
}

}  // namespace tribo::sim
