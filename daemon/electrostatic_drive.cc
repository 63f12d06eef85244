#include "daemon/electrostatic_drive.h"

#include <cmath>

namespace tribo::daemon {

ElectrostaticAxis electrostatic_axis_from_config(const v1::TransducerAxisConstants& c) {
  constexpr double kEpsilon0 = 8.8541878128e-12;  // F/m
  return ElectrostaticAxis{c.spring_n_per_m(), c.plate_area_m2(), c.gap_positive_m(), c.gap_negative_m(),
                           c.bias_v(),         c.max_drive_v(),   kEpsilon0 * c.relative_permittivity()};
}

namespace {

// The stiffness terms shared by assess_drive and drive_stiffness, computed
// by the same operations for both.
struct StiffnessTerms {
  bool gap_closed = false;
  double ea = 0, g_active = 0, v_active_sq = 0, k_other = 0, k_e = 0, k_total = 0, ratio = 0;
};

StiffnessTerms stiffness_terms(const ElectrostaticAxis& a, double force_n, double position_m,
                               double support_stiffness_n_per_m) {
  StiffnessTerms t;
  const double g_pos = a.gap_positive_m - position_m;
  const double g_neg = a.gap_negative_m + position_m;
  if (!(g_pos > 0) || !(g_neg > 0)) {
    t.gap_closed = true;
    return t;
  }
  t.ea = a.permittivity_f_per_m * a.plate_area_m2;
  // The active plate is on the side of the force; the other one holds the bias.
  const bool positive = force_n >= 0;
  t.g_active = positive ? g_pos : g_neg;
  const double g_other = positive ? g_neg : g_pos;
  const double bias_sq = a.bias_v * a.bias_v;
  t.v_active_sq = 2.0 * std::fabs(force_n) * t.g_active * t.g_active / t.ea +
                  bias_sq * (t.g_active * t.g_active) / (g_other * g_other);
  t.k_other = t.ea * bias_sq / (g_other * g_other * g_other);
  t.k_e = t.ea * t.v_active_sq / (t.g_active * t.g_active * t.g_active) + t.k_other;
  t.k_total = a.spring_n_per_m + support_stiffness_n_per_m;
  t.ratio = (t.k_total - t.k_e) / a.spring_n_per_m;
  return t;
}

}  // namespace

DriveStiffness drive_stiffness(const ElectrostaticAxis& a, double force_n, double position_m,
                               double support_stiffness_n_per_m) {
  const StiffnessTerms t = stiffness_terms(a, force_n, position_m, support_stiffness_n_per_m);
  return DriveStiffness{t.gap_closed, t.ratio};
}

bool stiffness_certainly_above(const ElectrostaticAxis& a, double force_n, double position_m,
                               double support_stiffness_n_per_m, double min_ratio) {
  const double g_pos = a.gap_positive_m - position_m;
  const double g_neg = a.gap_negative_m + position_m;
  if (!(g_pos > 0) || !(g_neg > 0) || !(min_ratio >= 0) || !(a.spring_n_per_m > 0)) return false;
  const bool positive = force_n >= 0;  // the active plate, as stiffness_terms picks it
  const double g_active = positive ? g_pos : g_neg;
  const double g_other = positive ? g_neg : g_pos;
  const double g_other_cubed = g_other * g_other * g_other;
  // Both sides of k_total - min k >= k_e, times g_a g_o^3 > 0; every term is
  // non-negative, so each carries a relative rounding error of a few 1e-16.
  const double ea_bias_sq = a.permittivity_f_per_m * a.plate_area_m2 * a.bias_v * a.bias_v;
  const double pulled = 2.0 * std::fabs(force_n) * g_other_cubed + ea_bias_sq * (g_other + g_active);
  const double k_total = a.spring_n_per_m + support_stiffness_n_per_m;
  const double k_floor = min_ratio * a.spring_n_per_m;
  const double box = g_active * g_other_cubed;
  constexpr double kMargin = 1e-9;
  return (k_total - k_floor) * box > pulled + kMargin * (pulled + (k_total + k_floor) * box);
}

DriveAssessment assess_drive(const ElectrostaticAxis& a, double force_n, double position_m,
                             double support_stiffness_n_per_m) {
  DriveAssessment out;
  const StiffnessTerms t = stiffness_terms(a, force_n, position_m, support_stiffness_n_per_m);
  if (t.gap_closed) {
    out.gap_closed = true;
    return out;
  }
  out.active_voltage_v = std::sqrt(t.v_active_sq);
  out.negative_stiffness_n_per_m = t.k_e;
  out.stiffness_ratio = t.ratio;
  const double headroom = t.k_total - t.k_other;
  out.pull_in_voltage_v =
      headroom > 0 ? std::sqrt(headroom * t.g_active * t.g_active * t.g_active / t.ea) : 0.0;
  return out;
}

}  // namespace tribo::daemon
