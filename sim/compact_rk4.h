// The specialised path of integrate_lateral, for speed: for a plant
// without backlash and without Maxwell-slip elements (every named instrument
// config), the RK4 or midpoint sub-steps run on the states in use only
// (x, v, z, and the contact age and rate-and-state states where their
// effect is enabled), with a derivative instantiated per combination of those
// two effects, chosen once per call by a switch (frictional lag, a third
// state, takes the general path). The general path
// (sim/lateral_plant.cc) carries every state of every plant through every
// stage (17 doubles a state, 19 an evaluation): here 3 to 6.
//
// Same operations in the same order as the general path, so the same bits:
// each derivative is lateral_derivative's for that plant with its branches on
// disabled effects taken, and each stage is add_scaled's "s + h r" on the
// states whose rate is not identically 0. The states left out keep their
// value, as in the general path, where they gain h x 0 = +0: the same value
// except for -0, so the path is taken only when none of them is -0
// (tests/sim/compact_rk4_test.cc holds both paths to the same bits on every
// combination).
#pragma once

#include "sim/lateral_plant.h"

namespace tribo::sim {

// True when integrate_lateral_compact gives integrate_lateral_general's bits.
bool compact_rk4_applies(const LateralPlant& plant, const LateralState& s);

// integrate_lateral for a plant where compact_rk4_applies.
bool integrate_lateral_compact(const LateralPlant& plant, const LateralInputs& in, double dt_s,
                               int substeps, LateralState& s, const LateralRate* first,
                               SubstepScheme scheme);

}  // namespace tribo::sim
