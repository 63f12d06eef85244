// Lateral (X) axis: the centre plate and tip (mass m) on the transducer spring
// k and damping c, driven by the actuator force and held back by friction:
//
//   dx/dt = v
//   m dv/dt = F_drive - k x - c v - F_friction(v, z)
//   dz/dt   = LuGre bristle rate (sim/lugre_friction.h)
//
// The drive force is held constant over a controller tick (zero-order hold);
// the tick is integrated in n equal sub-steps, n chosen from the present state
// (sim/step_size.h), by one of two schemes:
//
// - integrate_lateral: classical RK4 on (x, v, z), whenever the sub-steps
//   resolve every rate of the plant, including the bristle relaxation |v|/g(v).
// - integrate_lateral_split: at light loads g(v) ~ N -> 0 and the bristles
//   relax faster than any affordable step (|v|/g reaches 1e7 1/s on the first
//   tick of a loading ramp). For fixed v, dz/dt = v - a z with a = |v|/g(v) is
//   linear in z, so z is advanced exactly, z_ss + (z - z_ss) exp(-a h) with
//   z_ss = sgn(v) g(v), in a Strang splitting: half a step of z, an RK4 step
//   of (x, v) with z frozen, half a step of z. Second order, and L-stable in
//   the bristle mode: a fast-relaxing bristle lands on its steady state.
#pragma once

#include "sim/lugre_friction.h"

namespace tribo::sim {

struct LateralAxisParams {
  double mass_kg = 0;
  double spring_n_per_m = 0;
  double damping_n_s_per_m = 0;
};

struct LateralState {
  double position_m = 0;
  double velocity_m_per_s = 0;
  double bristle_m = 0;  // LuGre z
};

struct LateralDerivative {
  double dx = 0, dv = 0, dz = 0;
  double friction_n = 0;
};

LateralDerivative lateral_derivative(const LateralAxisParams& axis, const LugreParams& friction,
                                     const FrictionLevels& levels, const LateralState& s,
                                     double drive_n);

// Advances s by dt with n RK4 sub-steps under constant drive and load.
void integrate_lateral(const LateralAxisParams& axis, const LugreParams& friction,
                       const FrictionLevels& levels, double drive_n, double dt_s, int substeps,
                       LateralState& s);

// Advances s by dt with n split sub-steps (exact bristle relaxation).
void integrate_lateral_split(const LateralAxisParams& axis, const LugreParams& friction,
                             const FrictionLevels& levels, double drive_n, double dt_s,
                             int substeps, LateralState& s);

}  // namespace tribo::sim
