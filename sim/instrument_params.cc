#include "sim/instrument_params.h"

#include <cmath>
#include <sstream>

namespace tribo::sim {

InstrumentParams instrument_params_from_config(const v1::SimConfig& c) {
  InstrumentParams p;
  p.lateral = {c.lateral().moving_mass_kg(), c.lateral().spring_stiffness_n_per_m(),
               c.lateral().damping_n_s_per_m()};
  p.normal = {c.normal().spring_stiffness_n_per_m(), c.normal().tip_radius_m(),
              c.normal().reduced_modulus_pa()};
  const auto& f = c.friction();
  p.friction = {f.contact_stiffness_n_per_m(), f.bristle_damping_n_s_per_m(),
                f.viscous_n_s_per_m(),         f.static_coeff(),
                f.coulomb_coeff(),             f.stribeck_velocity_m_per_s(),
                f.stribeck_exponent(),         f.breakaway_ratio()};
  const auto& s = c.sensors();
  p.sensors.lateral_position_m = {s.lateral_position_noise_m(), s.lateral_position_resolution_m()};
  p.sensors.lateral_force_n = {s.lateral_force_noise_n(), s.lateral_force_resolution_n()};
  p.sensors.normal_force_n = {s.normal_force_noise_n(), s.normal_force_resolution_n()};
  p.sensors.normal_displacement_m = {s.normal_displacement_noise_m(),
                                     s.normal_displacement_resolution_m()};
  p.integrator = {c.integrator().max_h_lambda(), static_cast<int>(c.integrator().max_substeps())};
  return p;
}

namespace {

struct Check {
  const char* field;
  double value;
  double min;
  double max;
  bool min_inclusive;
};

std::optional<std::string> first_failure(std::initializer_list<Check> checks) {
  for (const Check& c : checks) {
    const bool low = c.min_inclusive ? !(c.value >= c.min) : !(c.value > c.min);
    if (low || !(c.value <= c.max) || !std::isfinite(c.value)) {
      std::ostringstream msg;
      msg << "sim." << c.field << " = " << c.value << ": must be in " << (c.min_inclusive ? "[" : "(")
          << c.min << ", " << c.max << "]";
      return msg.str();
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> validate_sim_config(const v1::SimConfig& c) {
  const auto& f = c.friction();
  const auto& s = c.sensors();
  return first_failure({
          {"lateral.moving_mass_kg", c.lateral().moving_mass_kg(), 0, 1, false},
          {"lateral.spring_stiffness_n_per_m", c.lateral().spring_stiffness_n_per_m(), 0, 1e6, true},
          {"lateral.damping_n_s_per_m", c.lateral().damping_n_s_per_m(), 0, 1e3, true},
          {"normal.spring_stiffness_n_per_m", c.normal().spring_stiffness_n_per_m(), 0, 1e6, false},
          {"normal.tip_radius_m", c.normal().tip_radius_m(), 0, 1e-2, false},
          {"normal.reduced_modulus_pa", c.normal().reduced_modulus_pa(), 0, 1e13, false},
          {"friction.contact_stiffness_n_per_m", f.contact_stiffness_n_per_m(), 0, 1e9, false},
          {"friction.bristle_damping_n_s_per_m", f.bristle_damping_n_s_per_m(), 0, 1e6, true},
          {"friction.viscous_n_s_per_m", f.viscous_n_s_per_m(), 0, 1e6, true},
          {"friction.static_coeff", f.static_coeff(), 0, 10, false},
          {"friction.coulomb_coeff", f.coulomb_coeff(), 0, 10, false},
          {"friction.stribeck_velocity_m_per_s", f.stribeck_velocity_m_per_s(), 0, 1, false},
          {"friction.stribeck_exponent", f.stribeck_exponent(), 0.25, 4, true},
          {"friction.breakaway_ratio", f.breakaway_ratio(), 0, 0.99, true},
          {"sensors.lateral_position_noise_m", s.lateral_position_noise_m(), 0, 1e-6, true},
          {"sensors.lateral_position_resolution_m", s.lateral_position_resolution_m(), 0, 1e-6, true},
          {"sensors.lateral_force_noise_n", s.lateral_force_noise_n(), 0, 1e-3, true},
          {"sensors.lateral_force_resolution_n", s.lateral_force_resolution_n(), 0, 1e-3, true},
          {"sensors.normal_force_noise_n", s.normal_force_noise_n(), 0, 1e-3, true},
          {"sensors.normal_force_resolution_n", s.normal_force_resolution_n(), 0, 1e-3, true},
          {"sensors.normal_displacement_noise_m", s.normal_displacement_noise_m(), 0, 1e-6, true},
          {"sensors.normal_displacement_resolution_m", s.normal_displacement_resolution_m(), 0, 1e-6, true},
          {"integrator.max_h_lambda", c.integrator().max_h_lambda(), 0, 2.5, false},
          {"integrator.max_substeps", static_cast<double>(c.integrator().max_substeps()), 1, 1e5, true},
  });
}

}  // namespace tribo::sim
