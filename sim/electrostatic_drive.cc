#include "sim/electrostatic_drive.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

double plate_voltage_for_force_v(double area_m2, double force_n, double gap_m) {
  return gap_m * std::sqrt(2.0 * std::max(0.0, force_n) / (kVacuumPermittivity_f_per_m * area_m2));
}

double DriveField::force_n(double x) const {
  double f = constant_n;
  if (coeff_positive > 0) {
    const double gap = std::max(gap_positive_m - x, stop_gap_m);
    f += coeff_positive / (gap * gap);
  }
  if (coeff_negative > 0) {
    const double gap = std::max(gap_negative_m + x, stop_gap_m);
    f -= coeff_negative / (gap * gap);
  }
  return f;
}

double DriveField::negative_stiffness_n_per_m(double x) const {
  double k = 0;
  if (coeff_positive > 0) {
    const double gap = std::max(gap_positive_m - x, stop_gap_m);
    k += 2 * coeff_positive / (gap * gap * gap);
  }
  if (coeff_negative > 0) {
    const double gap = std::max(gap_negative_m + x, stop_gap_m);
    k += 2 * coeff_negative / (gap * gap * gap);
  }
  return k;
}

double DriveField::potential_j(double x) const {
  double u = -constant_n * x;
  if (coeff_positive > 0) u -= coeff_positive / (gap_positive_m - x);
  if (coeff_negative > 0) u -= coeff_negative / (gap_negative_m + x);
  return u;
}

DriveField ideal_drive_field(double force_n) { return DriveField{force_n, 0, 0, 1, 1, 0}; }

DriveField electrostatic_drive_field(const ElectrostaticDriveParams& p, const PlateVoltages& v) {
  const double half_eps_a = 0.5 * kVacuumPermittivity_f_per_m * p.plates.area_m2;
  return DriveField{0,
                    half_eps_a * v.positive_v * v.positive_v,
                    half_eps_a * v.negative_v * v.negative_v,
                    p.plates.gap_positive_m,
                    p.plates.gap_negative_m,
                    p.stop_gap_m};
}

double electrostatic_stiffness_n_per_m(const PlateGeometry& plates, const PlateVoltages& v,
                                       double x) {
  const double eps_a = kVacuumPermittivity_f_per_m * plates.area_m2;
  return eps_a * v.positive_v * v.positive_v / std::pow(plates.gap_positive_m - x, 3) +
         eps_a * v.negative_v * v.negative_v / std::pow(plates.gap_negative_m + x, 3);
}

DriveOutput DriveElectronics::command(double force_n, double x, double dt_s) {
  const PlateGeometry& c = p_.calibrated;
  const double gap_pos = c.gap_positive_m - x, gap_neg = c.gap_negative_m + x;
  const double bias_pos = plate_force_n(c.area_m2, p_.bias_voltage_v, gap_pos);
  const double bias_neg = plate_force_n(c.area_m2, p_.bias_voltage_v, gap_neg);
  const int side = force_n >= bias_pos - bias_neg ? +1 : -1;
  if (side != side_) {
    side_ = side;
    handover_left_s_ = p_.handover_time_s;
  }
  DriveOutput out;
  out.bias = out.voltages = PlateVoltages{p_.bias_voltage_v, p_.bias_voltage_v};
  out.dead_time_s = std::min(handover_left_s_, dt_s);
  handover_left_s_ -= out.dead_time_s;
  // The driven plate must pull with |F| plus the other plate's bias pull.
  if (side > 0) {
    out.voltages.positive_v =
        std::min(p_.max_voltage_v, plate_voltage_for_force_v(c.area_m2, force_n + bias_neg, gap_pos));
  } else {
    out.voltages.negative_v =
        std::min(p_.max_voltage_v, plate_voltage_for_force_v(c.area_m2, bias_pos - force_n, gap_neg));
  }
  return out;
}

double DriveElectronics::believed_force_n(const PlateVoltages& v, double x) const {
  const PlateGeometry& c = p_.calibrated;
  return plate_force_n(c.area_m2, v.positive_v, c.gap_positive_m - x) -
         plate_force_n(c.area_m2, v.negative_v, c.gap_negative_m + x);
}

}  // namespace tribo::sim
