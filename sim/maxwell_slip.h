// Presliding hysteresis with memory: a generalized Maxwell-slip set of
// bristles (Al-Bender, Lampaert, Swevers 2005) replacing LuGre's single
// bristle. Element i of n has stiffness sigma0 / n and slips at a deflection
// c_i g(v), the shares spread evenly over 1 +- spread (their mean is 1):
//
//   c_i    = 1 + spread (2 i / (n - 1) - 1)
//   dz_i/dt = v - alpha_r(z_i, v, c_i g) |v| z_i / (c_i g)       (elasto-plastic,
//                                                                   sim/lugre_friction.h)
//   F      = sum_i (sigma0 z_i + sigma1 dz_i/dt) / n + sigma2 v
//
// In steady sliding every element sits at c_i g, so F = S(v) + sigma2 v as
// for one bristle; in presliding the elements slip one after another, giving
// a hysteresis loop whose inner loops close where they began (non-local memory,
// Masing behaviour), which one LuGre bristle cannot do.
#pragma once

#include <array>

namespace tribo::sim {

inline constexpr int kMaxSlipElements = 8;

struct PreslidingHysteresisParams {
  bool enabled = false;
  int elements = 4;
  double spread = 0.5;
  double breakaway_ratio = 0.9;
};

// c_i of element i.
double slip_share(const PreslidingHysteresisParams& p, int element);

using SlipElements = std::array<double, kMaxSlipElements>;

}  // namespace tribo::sim
