// The lateral axis's electrostatic drive (dissertation §3.2.5,
// §5.1.1). The controller commands a force in newtons; the drive electronics
// turn it into plate voltages with their calibration, and the plates pull
// with the true law, which the plant feels at its true position:
//
//   F(x) = eps0 A V+^2 / (2 (d+ - x)^2) - eps0 A V-^2 / (2 (d- + x)^2)
//
// Both drive plates carry a DC bias Vb (it linearises the force per volt);
// the drive voltage is added to one plate at a time: V+ = Vb + u, V- = Vb for
// a force above the bias-only force F_b(x) = F(x; Vb, Vb), the other way
// round below it. The electronics solve for u with their calibrated A, d+,
// d- at the measured position, so with a perfect calibration the force equals
// the command; d+ != d- makes the force constant differ per side.
//
// Breakpoint: whenever the driven plate changes, neither plate is driven (only
// the bias acts) for handover_time_s from the start of that tick (spilling
// into the next ticks if longer) -- the loop briefly loses control of the
// force. The plant integrates the dead interval and the rest of the tick
// separately, so the handover means the same at every loop rate.
//
// Snap-down: the electrostatic force has a negative stiffness
//   k_e(x) = eps0 A V+^2 / (d+ - x)^3 + eps0 A V-^2 / (d- + x)^3,
// and the plate is statically stable while k_eff = k - k_e > 0. If the plate
// reaches a stop at gap stop_gap_m it snaps onto it and stays there while the
// net force holds it (sim/lateral_plant.h).
#pragma once

#include "sim/parallel_plates.h"

namespace tribo::sim {

struct ElectrostaticDriveParams {
  bool enabled = false;        // false: an ideal force actuator (F = command)
  PlateGeometry plates;        // true geometry
  PlateGeometry calibrated;    // what the electronics assume
  double bias_voltage_v = 0;
  double max_voltage_v = 0;
  double handover_time_s = 0;
  double stop_gap_m = 0;
};

struct PlateVoltages {
  double positive_v = 0;
  double negative_v = 0;
};

// The drive force on the centre plate for one tick (voltages held): an ideal
// actuator's constant force plus the plates' attraction at position x. Gaps
// below the stop gap are evaluated at the stop gap, so the force stays finite.
struct DriveField {
  double constant_n = 0;
  double coeff_positive = 0;  // eps0 A V+^2 / 2, N m^2
  double coeff_negative = 0;
  double gap_positive_m = 1;
  double gap_negative_m = 1;
  double stop_gap_m = 0;

  double force_n(double x_m) const;
  double negative_stiffness_n_per_m(double x_m) const;  // k_e = dF/dx
  // Potential of the electrostatic force at fixed voltages: -C V^2 / 2 per plate.
  double potential_j(double x_m) const;
  bool has_stops() const { return coeff_positive > 0 || coeff_negative > 0; }
  double stop_positive_m() const { return gap_positive_m - stop_gap_m; }
  double stop_negative_m() const { return -(gap_negative_m - stop_gap_m); }
};

DriveField ideal_drive_field(double force_n);
DriveField electrostatic_drive_field(const ElectrostaticDriveParams& p, const PlateVoltages& v);

// k_e at position x for plate voltages v (see above).
double electrostatic_stiffness_n_per_m(const PlateGeometry& plates, const PlateVoltages& v,
                                       double x_m);

// What the electronics apply over the coming tick: the bias alone for
// dead_time_s (a handover), then the voltages.
struct DriveOutput {
  PlateVoltages voltages;
  PlateVoltages bias;
  double dead_time_s = 0;
};

// The drive electronics: one decision per tick.
class DriveElectronics {
 public:
  explicit DriveElectronics(const ElectrostaticDriveParams& p) : p_(p) {}

  // Voltages for the coming tick to apply force_n at the measured position.
  DriveOutput command(double force_n, double measured_position_m, double dt_s);

  // The force the electronics believe the voltages apply at the measured
  // position, with their calibration: what the transducer reports.
  double believed_force_n(const PlateVoltages& v, double measured_position_m) const;

  int driven_side() const { return side_; }  // +1 or -1

 private:
  ElectrostaticDriveParams p_;
  int side_ = +1;
  double handover_left_s_ = 0;
};

}  // namespace tribo::sim
