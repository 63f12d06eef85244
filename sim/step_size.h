// How a controller tick is integrated: how many sub-steps, and by which scheme
// (sim/lateral_plant.h). The plant is stiff (with the Appendix C numbers the
// damping rate alone is ~1e4..4e4 1/s), so the sub-step h follows from a bound
// lambda on the magnitude of the plant's eigenvalues at the present state:
// h * lambda <= max_h_lambda. The bound is a Gershgorin-style row sum of the
// Jacobian of (x, v, z):
//
//   lambda = (c + sigma2 + sigma1 |d(dz/dt)/dv|) / m      damping of v
//          + v_reach / g_min                              bristle relaxation |v|/g
//          + sqrt((k + sigma0) / m)                       spring and bristle stiffness
//
// with v_reach = |v| + |dv/dt| dt (the speed reachable within the tick),
// g_min = min(Fs, Fc) / sigma0, and |d(dz/dt)/dv| <= 1 + (|z|/g_min)(1 + |Fs-Fc|/(e min(Fs,Fc)))
// (the last term bounds |v| g'(v)/g for the exponential and Gaussian shapes).
//
// If that many RK4 sub-steps fit under max_substeps, the tick uses plain RK4.
// Otherwise the bristle relaxation is what cannot be resolved (light loads),
// and the tick uses the split scheme, whose z-step is exact: its bound drops
// the relaxation term and takes |z|/g_min <= max(Fs, Fc)/min(Fs, Fc).
// RK4 is stable for h lambda up to 2.78 on the negative real axis; 1.0 keeps
// the stiff modes accurate as well as stable.
#pragma once

#include "sim/lateral_plant.h"

namespace tribo::sim {

struct LateralRates {
  double full_per_s = 0;   // all modes, for plain RK4
  double split_per_s = 0;  // without the bristle relaxation, for the split scheme
};

LateralRates lateral_rate_bounds(const LateralAxisParams& axis, const LugreParams& friction,
                                 const FrictionLevels& levels, const LateralState& s,
                                 double drive_n, double dt_s);

struct StepPlan {
  int substeps = 1;
  bool split = false;   // use integrate_lateral_split
  bool capped = false;  // even the split scheme wanted more than max_substeps
};

StepPlan plan_substeps(const LateralRates& rates, double dt_s, double max_h_lambda,
                       int max_substeps);

}  // namespace tribo::sim
