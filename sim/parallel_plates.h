// The three-plate capacitor of a Hysitron transducer axis (dissertation §5.1.1-5.1.2):
// the centre plate at x sits between a "+" plate at gap gap_positive - x and a
// "-" plate at gap gap_negative + x. The same plates drive (electrostatic
// attraction) and sense (differential capacitance).
#pragma once

namespace tribo::sim {

inline constexpr double kVacuumPermittivity_f_per_m = 8.8541878128e-12;

struct PlateGeometry {
  double area_m2 = 0;
  double gap_positive_m = 0;
  double gap_negative_m = 0;
};

// Attraction towards one plate at voltage V across gap: eps0 A V^2 / (2 gap^2).
inline double plate_force_n(double area_m2, double voltage_v, double gap_m) {
  return kVacuumPermittivity_f_per_m * area_m2 * voltage_v * voltage_v / (2.0 * gap_m * gap_m);
}

// Voltage that pulls with force_n (>= 0) across gap.
double plate_voltage_for_force_v(double area_m2, double force_n, double gap_m);

}  // namespace tribo::sim
