// Normal (Z) axis, open loop and quasi-static: the actuator force F presses a
// spring-suspended plate, and the tip into the sample. With the tip touching
// the surface at zero force, the plate displacement d (into the sample) obeys
//
//   F = k_spring d + N_hertz(d),   N_hertz(d) = (4/3) E* sqrt(R) d^(3/2)   (d > 0)
//
// so part of the commanded load is absorbed by the springs (physics.md §1).
// For F <= 0 the tip lifts off: d = F / k_spring, N = 0. Hertz contact on the
// spherical end of a cono-spherical tip (physics.md §7).
#pragma once

namespace tribo::sim {

struct NormalAxisParams {
  double spring_n_per_m = 0;
  double tip_radius_m = 0;
  double reduced_modulus_pa = 0;  // E*
};

struct NormalEquilibrium {
  double displacement_m = 0;  // positive into the sample
  double contact_load_n = 0;
};

NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double actuator_force_n);

// Hertz: depth for a contact load, and contact radius a = sqrt(R depth).
double hertz_depth_m(const NormalAxisParams& p, double contact_load_n);
double hertz_contact_radius_m(const NormalAxisParams& p, double contact_load_n);

}  // namespace tribo::sim
