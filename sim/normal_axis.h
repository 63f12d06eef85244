// Normal (Z) axis, open loop and quasi-static (dissertation §5.4,
// §3, §4.4). The controller commands a force; the electronics turn it into a
// plate voltage with their calibration at the measured plate displacement,
// and the plate pulls with the true law at the true displacement:
//
//   F = F_cmd (A / A_cal) ((d_cal - z_meas) / (d - z))^2     (pressing; the
//       other plate, gap d + z, for F_cmd < 0)
//
// (z from the previous tick: the plate moves nanometres per tick against a
// gap of tens of micrometres.) The spring-suspended plate presses the tip into
// the sample; with the surface at height h(x) = x tan(slope) under the tip
// and touched at zero force at x = 0, the plate displacement z (positive into
// the sample) obeys
//
//   F = k_spring z + N_hertz(z + h),   N_hertz(d) = (4/3) E* sqrt(R) d^(3/2)   (d > 0)
//
// so part of the commanded load is absorbed by the springs, and more of it
// where the surface rises (open loop cannot hold a low load constant). For
// F <= k h the tip lifts off: z = F / k, N = 0. Hertz contact holds on the
// spherical end of the cono-spherical tip, down to the depth R cos^2(alpha)
// where the contact radius reaches the sphere-cone junction R cos(alpha)
// (alpha the cone half angle); the loads of the instrument (<= 10 mN, ~150 nm
// with the 50 um tip) stay far above that (25 um for alpha = 45 deg).
//
// The transducer reports the load it believes it applies minus the spring:
//   N_reported = F_cmd - k_cal z_meas.
#pragma once

#include "sim/parallel_plates.h"

namespace tribo::sim {

struct NormalAxisParams {
  double spring_n_per_m = 0;
  double tip_radius_m = 0;
  double reduced_modulus_pa = 0;  // E*
  double cone_half_angle_rad = 0;
  double plate_area_m2 = 0;       // 0: ideal force actuator
  double gap_m = 0;
  double calibrated_area_m2 = 0;
  double calibrated_gap_m = 0;
  double calibrated_spring_n_per_m = 0;
};

struct NormalEquilibrium {
  double displacement_m = 0;  // plate, positive into the sample
  double contact_load_n = 0;
  double depth_m = 0;         // Hertz approach z + h
};

// The true actuator force for a command, given the measured and the true
// plate displacement.
double normal_actuator_force_n(const NormalAxisParams& p, double command_n, double measured_m,
                               double true_m);

// Quasi-static equilibrium under actuator force F with the surface at height
// h. A previous solution's depth speeds up the solve (Newton from there).
NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double actuator_force_n,
                                           double surface_height_m = 0, double depth_guess_m = 0);

// Hertz's (4/3) E* sqrt(R), N/m^1.5.
double hertz_coefficient(const NormalAxisParams& p);
// The same solve with hertz_coefficient(p) computed once by the caller (the
// simulated instrument solves every tick: a square root fewer, same bits).
NormalEquilibrium solve_normal_equilibrium(const NormalAxisParams& p, double hertz_coefficient,
                                           double actuator_force_n, double surface_height_m,
                                           double depth_guess_m);

// What the transducer reports as the normal load.
double reported_normal_force_n(const NormalAxisParams& p, double command_n, double measured_m);

// Hertz: depth for a contact load, and contact radius a = sqrt(R depth).
double hertz_depth_m(const NormalAxisParams& p, double contact_load_n);
double hertz_contact_radius_m(const NormalAxisParams& p, double contact_load_n);
// Depth at which the contact reaches the sphere-cone junction: R cos^2(alpha).
double spherical_cap_depth_m(const NormalAxisParams& p);

}  // namespace tribo::sim
