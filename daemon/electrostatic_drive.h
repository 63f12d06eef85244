// The nominal electrostatic drive of a three-plate capacitive transducer axis
// (dissertation §5.1.1, eqs. 16-19): which plate voltages produce a drive force at the present
// position, the negative stiffness they add, and how close the plate is to
// snap-down (pull-in). The supervisor and the validator use it with the
// config's nominal constants (tribo.v1.TransducerConstants), never with the
// simulator's parameters, so the same checks run against real hardware.
//
// Drive model: the centre plate (tip) is grounded; the drive plates sit at
// gaps g+ = d+ - x and g- = d- + x (x towards the + plate) and both carry the
// bias Vb. A force F > 0 raises the + plate to V+ (the - plate stays at Vb),
// F < 0 the - plate: one plate at a time, as in the dissertation (§3.2.5).
//
//   F   = eps A / 2 (V+^2 / g+^2 - V-^2 / g-^2)
//   k_e = eps A (V+^2 / g+^3 + V-^2 / g-^3)          negative stiffness
//   k_eff = k_spring + k_support - k_e               must stay positive
//
// k_support is whatever else holds the plate (the contact, for the normal
// axis under load). The pull-in voltage at the present gap is the active
// plate's voltage at which k_eff reaches 0; from rest with the spring alone
// (no bias) it is sqrt(8 k d^3 / (27 eps A)) at x = d/3 (143 V for d = 85 µm,
// k = 100 N/m, A = 1 cm^2), which this reproduces at x = d/3.
#pragma once

#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

struct ElectrostaticAxis {
  double spring_n_per_m = 0;
  double plate_area_m2 = 0;
  double gap_positive_m = 0;
  double gap_negative_m = 0;
  double bias_v = 0;
  double max_drive_v = 0;
  double permittivity_f_per_m = 8.8541878128e-12;  // eps0 eps_r
};

struct DriveAssessment {
  bool gap_closed = false;         // x at or beyond a plate: no valid state
  double active_voltage_v = 0;     // the raised plate's voltage
  double negative_stiffness_n_per_m = 0;
  double stiffness_ratio = 0;      // k_eff / k_spring
  double pull_in_voltage_v = 0;    // of the active plate at this gap and support
};

ElectrostaticAxis electrostatic_axis_from_config(const v1::TransducerAxisConstants& c);

DriveAssessment assess_drive(const ElectrostaticAxis& axis, double force_n, double position_m,
                             double support_stiffness_n_per_m);

// What the supervisor checks every tick: assess_drive's gap_closed and
// stiffness_ratio (the same values), without the two voltages' square roots,
// which only a trip's message needs (they cost 8 % of an in-process run).
struct DriveStiffness {
  bool gap_closed = false;
  double stiffness_ratio = 0;
};
DriveStiffness drive_stiffness(const ElectrostaticAxis& axis, double force_n, double position_m,
                               double support_stiffness_n_per_m);

// true when the drive certainly keeps the gap open and k_eff / k at or above
// min_ratio, i.e. drive_stiffness(...) certainly gives !gap_closed and
// stiffness_ratio >= min_ratio; false when that is not certain (near the
// limit, beyond it, or not finite: then ask drive_stiffness). Decided without
// a division (drive_stiffness's ten a tick would cost the supervisor most
// of its time), from k_e g_a g_o^3 = 2 |F| g_o^3 + eps A Vb^2 (g_o + g_a) (g_a
// the active plate's gap, g_o the other's), with a relative margin of 1e-9
// against rounding that is ~1e-15: the supervisor's decisions stay the same.
bool stiffness_certainly_above(const ElectrostaticAxis& axis, double force_n, double position_m,
                               double support_stiffness_n_per_m, double min_ratio);

}  // namespace tribo::daemon
