#include "daemon/electrostatic_drive.h"

#include <cmath>

namespace tribo::daemon {

ElectrostaticAxis electrostatic_axis_from_config(const v1::TransducerAxisConstants& c) {
  constexpr double kEpsilon0 = 8.8541878128e-12;  // F/m
  return ElectrostaticAxis{c.spring_n_per_m(), c.plate_area_m2(), c.gap_positive_m(), c.gap_negative_m(),
                           c.bias_v(),         c.max_drive_v(),   kEpsilon0 * c.relative_permittivity()};
}

DriveAssessment assess_drive(const ElectrostaticAxis& a, double force_n, double position_m,
                             double support_stiffness_n_per_m) {
  DriveAssessment out;
  const double g_pos = a.gap_positive_m - position_m;
  const double g_neg = a.gap_negative_m + position_m;
  if (!(g_pos > 0) || !(g_neg > 0)) {
    out.gap_closed = true;
    return out;
  }
  const double ea = a.permittivity_f_per_m * a.plate_area_m2;
  // The active plate is on the side of the force; the other one holds the bias.
  const bool positive = force_n >= 0;
  const double g_active = positive ? g_pos : g_neg;
  const double g_other = positive ? g_neg : g_pos;
  const double bias_sq = a.bias_v * a.bias_v;
  const double v_active_sq =
      2.0 * std::fabs(force_n) * g_active * g_active / ea + bias_sq * (g_active * g_active) / (g_other * g_other);
  const double k_other = ea * bias_sq / (g_other * g_other * g_other);
  const double k_e = ea * v_active_sq / (g_active * g_active * g_active) + k_other;
  const double k_total = a.spring_n_per_m + support_stiffness_n_per_m;
  out.active_voltage_v = std::sqrt(v_active_sq);
  out.negative_stiffness_n_per_m = k_e;
  out.stiffness_ratio = (k_total - k_e) / a.spring_n_per_m;
  const double headroom = k_total - k_other;
  out.pull_in_voltage_v = headroom > 0 ? std::sqrt(headroom * g_active * g_active * g_active / ea) : 0.0;
  return out;
}

}  // namespace tribo::daemon
