#include "sim/instrument_params.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

namespace tribo::sim {

namespace {

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

// A calibration field of 0 means "the true value".
double or_true(double calibrated, double true_value) { return calibrated > 0 ? calibrated : true_value; }

}  // namespace

InstrumentParams instrument_params_from_config(const v1::SimConfig& c) {
  InstrumentParams p;
  const auto& lat = c.lateral();
  const auto& tip = c.tip();
  p.lateral = {lat.moving_mass_kg(), lat.spring_stiffness_n_per_m(), lat.damping_n_s_per_m(),
               BacklashParams{tip.backlash().enabled(), tip.backlash().width_m(),
                              tip.backlash().tip_mass_kg(), tip.backlash().coupling_stiffness_n_per_m(),
                              tip.backlash().coupling_damping_n_s_per_m()}};
  p.lateral_calibrated_spring_n_per_m =
      or_true(lat.calibration().spring_stiffness_n_per_m(), lat.spring_stiffness_n_per_m());
  const PlateGeometry plates{lat.plate_area_m2(), lat.gap_positive_m(), lat.gap_negative_m()};
  const PlateGeometry calibrated{or_true(lat.calibration().plate_area_m2(), plates.area_m2),
                                 or_true(lat.calibration().gap_positive_m(), plates.gap_positive_m),
                                 or_true(lat.calibration().gap_negative_m(), plates.gap_negative_m)};
  const auto& d = lat.drive();
  p.lateral_drive = {d.enabled(), plates, calibrated, d.bias_voltage_v(), d.max_voltage_v(),
                     d.handover_time_s(), d.stop_gap_m()};
  const auto& s = lat.sensing();
  p.lateral_sensing = {plates,
                       calibrated,
                       s.excitation_voltage_v(),
                       s.feedback_capacitance_f(),
                       s.adc_bits(),
                       s.adc_full_scale_v(),
                       s.white_noise_m(),
                       s.low_frequency_noise_m(),
                       s.low_frequency_corner_hz(),
                       s.drift_m_per_s()};

  const auto& n = c.normal();
  p.normal = {n.spring_stiffness_n_per_m(),
              n.tip_radius_m(),
              n.reduced_modulus_pa(),
              radians(n.cone_half_angle_deg()),
              n.plate_area_m2(),
              n.gap_m(),
              or_true(n.calibration().plate_area_m2(), n.plate_area_m2()),
              or_true(n.calibration().gap_positive_m(), n.gap_m()),
              or_true(n.calibration().spring_stiffness_n_per_m(), n.spring_stiffness_n_per_m())};

  const auto& f = c.friction();
  FrictionModel& m = p.friction;
  m.lugre = {f.contact_stiffness_n_per_m(), f.bristle_damping_n_s_per_m(),
             f.viscous_n_s_per_m(),         f.static_coeff(),
             f.coulomb_coeff(),             f.stribeck_velocity_m_per_s(),
             f.stribeck_exponent(),         f.breakaway_ratio()};
  m.dwell_stiction = {f.dwell_stiction().enabled(), f.dwell_stiction().gain(),
                      f.dwell_stiction().time_constant_s(), f.dwell_stiction().memory_length_m()};
  m.frictional_lag = {f.frictional_lag().enabled(), f.frictional_lag().time_constant_s()};
  m.velocity_strengthening = {f.velocity_strengthening().enabled(), f.velocity_strengthening().coeff(),
                              f.velocity_strengthening().reference_velocity_m_per_s()};
  m.load_dependence = {f.load_dependence().enabled(), f.load_dependence().adhesion_load_n(),
                       f.load_dependence().exponent(), f.load_dependence().reference_load_n()};
  m.position_periodic = {f.position_periodic().enabled(), f.position_periodic().amplitude(),
                         f.position_periodic().period_m(), radians(f.position_periodic().phase_deg())};
  m.orientation_anisotropy = {f.orientation_anisotropy().enabled(), f.orientation_anisotropy().amplitude(),
                              f.orientation_anisotropy().period_deg(), f.orientation_anisotropy().max_at_deg()};
  m.direction_asymmetry = {f.direction_asymmetry().enabled(), f.direction_asymmetry().ratio()};
  m.presliding_hysteresis = {f.presliding_hysteresis().enabled(),
                             static_cast<int>(f.presliding_hysteresis().elements()),
                             f.presliding_hysteresis().spread(), f.presliding_hysteresis().breakaway_ratio()};
  m.rate_state = {f.rate_state().enabled(), f.rate_state().direct_coeff(), f.rate_state().state_coeff(),
                  f.rate_state().reference_velocity_m_per_s(), f.rate_state().memory_length_m(),
                  f.rate_state().initial_state_s(),
                  f.rate_state().law() == v1::RATE_STATE_AGEING ? StateLaw::kAgeing : StateLaw::kSlip,
                  f.rate_state().direct_effect_rate() == v1::RATE_STATE_DIRECT_SLIP_RATE ? DirectEffectRate::kSlipRate
                                                                                       : DirectEffectRate::kTipVelocity};

  p.tilt = {tip.tilt_offset().enabled(), radians(tip.tilt_offset().angle_deg())};
  const auto& smp = c.sample();
  p.sample.rotation_deg = smp.rotation_deg();
  p.sample.slope_rad = radians(smp.slope_deg());
  p.sample.drift = {smp.drift().enabled(), smp.drift().rate_m_per_s(), smp.drift().velocity_rms_m_per_s(),
                    smp.drift().correlation_time_s()};
  p.sample.wear = {smp.wear().enabled(),         smp.wear().steady_state_ratio(),
                   smp.wear().decay_per_pass(),  smp.wear().reference_load_n(),
                   smp.wear().load_exponent(),   smp.wear().bin_width_m()};
  p.sample.heterogeneity = {smp.heterogeneity().enabled(), smp.heterogeneity().rms()};

  const auto& sn = c.sensors();
  p.sensors.lateral_force_n = {sn.lateral_force_noise_n(), sn.lateral_force_resolution_n()};
  p.sensors.normal_force_n = {sn.normal_force_noise_n(), sn.normal_force_resolution_n()};
  p.sensors.normal_displacement_m = {sn.normal_displacement_noise_m(), sn.normal_displacement_resolution_m()};
  p.sensors.normal_displacement_drift_m_per_s = sn.normal_displacement_drift_m_per_s();
  p.sensors.lateral_position_record_noise_m = sn.lateral_position_record_noise_m();
  p.integrator = {c.integrator().max_h_lambda(), static_cast<int>(c.integrator().max_substeps()),
                  c.integrator().method() == v1::INTEGRATION_MIDPOINT,
                  c.integrator().method() == v1::INTEGRATION_RK4_HELD_CONTACT,
                  c.integrator().contact_law_tolerance_n()};
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

std::optional<std::string> first_failure(const std::vector<Check>& checks) {
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

std::optional<std::string> fail(const std::string& field, double value, const std::string& why) {
  std::ostringstream msg;
  msg << "sim." << field << " = " << value << ": " << why;
  return msg.str();
}

std::optional<std::string> validate_lateral(const v1::LateralTransducerParams& l) {
  const auto& cal = l.calibration();
  const auto& d = l.drive();
  const auto& s = l.sensing();
  if (auto e = first_failure({
          {"lateral.moving_mass_kg", l.moving_mass_kg(), 0, 1, false},
          {"lateral.spring_stiffness_n_per_m", l.spring_stiffness_n_per_m(), 0, 1e6, false},
          {"lateral.damping_n_s_per_m", l.damping_n_s_per_m(), 0, 1e3, true},
          {"lateral.plate_area_m2", l.plate_area_m2(), 0, 1e-2, false},
          {"lateral.gap_positive_m", l.gap_positive_m(), 20e-6, 1e-3, false},
          {"lateral.gap_negative_m", l.gap_negative_m(), 20e-6, 1e-3, false},
          {"lateral.calibration.plate_area_m2", cal.plate_area_m2(), 0, 1e-2, true},
          {"lateral.calibration.gap_positive_m", cal.gap_positive_m(), 0, 1e-3, true},
          {"lateral.calibration.gap_negative_m", cal.gap_negative_m(), 0, 1e-3, true},
          {"lateral.calibration.spring_stiffness_n_per_m", cal.spring_stiffness_n_per_m(), 0, 1e6, true},
          {"lateral.sensing.excitation_voltage_v", s.excitation_voltage_v(), 0, 1e3, false},
          {"lateral.sensing.feedback_capacitance_f", s.feedback_capacitance_f(), 0, 1e-6, false},
          {"lateral.sensing.adc_bits", static_cast<double>(s.adc_bits()), 0, 32, true},
          {"lateral.sensing.adc_full_scale_v", s.adc_full_scale_v(), 0, 1e3, s.adc_bits() == 0},
          {"lateral.sensing.white_noise_m", s.white_noise_m(), 0, 1e-6, true},
          {"lateral.sensing.low_frequency_noise_m", s.low_frequency_noise_m(), 0, 1e-6, true},
          {"lateral.sensing.low_frequency_corner_hz", s.low_frequency_corner_hz(), 0, 1e4,
           s.low_frequency_noise_m() == 0},
          {"lateral.sensing.drift_m_per_s", std::fabs(s.drift_m_per_s()), 0, 1e-6, true},
      })) {
    return e;
  }
  if (!d.enabled()) return std::nullopt;
  const double min_gap = std::min(l.gap_positive_m(), l.gap_negative_m());
  if (auto e = first_failure({
          {"lateral.drive.bias_voltage_v", d.bias_voltage_v(), 0, 1e4, true},
          {"lateral.drive.max_voltage_v", d.max_voltage_v(), d.bias_voltage_v(), 1e4, false},
          {"lateral.drive.handover_time_s", d.handover_time_s(), 0, 1, true},
          {"lateral.drive.stop_gap_m", d.stop_gap_m(), 0, 0.5 * min_gap, false},
      })) {
    return e;
  }
  // The biased plates alone must leave the centre plate stable at rest:
  // k - eps0 A Vb^2 (1/d+^3 + 1/d-^3) > 0 (dissertation §5.1.1, eqs. 16-19).
  const PlateGeometry g{l.plate_area_m2(), l.gap_positive_m(), l.gap_negative_m()};
  const double k_bias = electrostatic_stiffness_n_per_m(g, {d.bias_voltage_v(), d.bias_voltage_v()}, 0.0);
  if (!(k_bias < l.spring_stiffness_n_per_m())) {
    return fail("lateral.drive.bias_voltage_v", d.bias_voltage_v(),
                "the bias alone snaps the plate down (negative stiffness " + std::to_string(k_bias) +
                    " N/m >= spring)");
  }
  return std::nullopt;
}

std::optional<std::string> validate_normal(const v1::NormalAxisParams& n) {
  const bool electrostatic = n.plate_area_m2() > 0;
  return first_failure({
      {"normal.spring_stiffness_n_per_m", n.spring_stiffness_n_per_m(), 0, 1e6, false},
      {"normal.tip_radius_m", n.tip_radius_m(), 0, 1e-2, false},
      {"normal.reduced_modulus_pa", n.reduced_modulus_pa(), 0, 1e13, false},
      {"normal.cone_half_angle_deg", n.cone_half_angle_deg(), 0, 90, false},
      {"normal.plate_area_m2", n.plate_area_m2(), 0, 1e-2, true},
      {"normal.gap_m", n.gap_m(), electrostatic ? 1e-6 : 0, 1e-3, !electrostatic},
      {"normal.calibration.plate_area_m2", n.calibration().plate_area_m2(), 0, 1e-2, true},
      {"normal.calibration.gap_positive_m", n.calibration().gap_positive_m(), 0, 1e-3, true},
      {"normal.calibration.spring_stiffness_n_per_m", n.calibration().spring_stiffness_n_per_m(), 0, 1e6, true},
  });
}

std::optional<std::string> validate_friction(const v1::FrictionParams& f) {
  std::vector<Check> checks = {
      {"friction.contact_stiffness_n_per_m", f.contact_stiffness_n_per_m(), 0, 1e9, false},
      {"friction.bristle_damping_n_s_per_m", f.bristle_damping_n_s_per_m(), 0, 1e6, true},
      {"friction.viscous_n_s_per_m", f.viscous_n_s_per_m(), 0, 1e6, true},
      {"friction.static_coeff", f.static_coeff(), 0, 10, false},
      {"friction.coulomb_coeff", f.coulomb_coeff(), 0, 10, false},
      {"friction.stribeck_velocity_m_per_s", f.stribeck_velocity_m_per_s(), 0, 1, false},
      {"friction.stribeck_exponent", f.stribeck_exponent(), 0.25, 4, true},
      {"friction.breakaway_ratio", f.breakaway_ratio(), 0, 0.99, true},
  };
  if (f.dwell_stiction().enabled()) {
    checks.push_back({"friction.dwell_stiction.gain", f.dwell_stiction().gain(), 0, 10, true});
    checks.push_back({"friction.dwell_stiction.time_constant_s", f.dwell_stiction().time_constant_s(), 0, 1e6, false});
    checks.push_back({"friction.dwell_stiction.memory_length_m", f.dwell_stiction().memory_length_m(), 1e-12, 1e-3, true});
  }
  if (f.frictional_lag().enabled()) {
    checks.push_back({"friction.frictional_lag.time_constant_s", f.frictional_lag().time_constant_s(), 1e-6, 10, true});
  }
  if (f.velocity_strengthening().enabled()) {
    checks.push_back({"friction.velocity_strengthening.coeff", f.velocity_strengthening().coeff(), 0, 1, true});
    checks.push_back({"friction.velocity_strengthening.reference_velocity_m_per_s",
                      f.velocity_strengthening().reference_velocity_m_per_s(), 1e-12, 1, true});
  }
  if (f.load_dependence().enabled()) {
    checks.push_back({"friction.load_dependence.adhesion_load_n", f.load_dependence().adhesion_load_n(), 0, 1, true});
    checks.push_back({"friction.load_dependence.exponent", f.load_dependence().exponent(), 0.1, 2, true});
    checks.push_back({"friction.load_dependence.reference_load_n", f.load_dependence().reference_load_n(), 0, 1, false});
  }
  if (f.position_periodic().enabled()) {
    checks.push_back({"friction.position_periodic.amplitude", f.position_periodic().amplitude(), 0, 0.9, true});
    checks.push_back({"friction.position_periodic.period_m", f.position_periodic().period_m(), 1e-10, 1e-3, true});
  }
  if (f.orientation_anisotropy().enabled()) {
    checks.push_back({"friction.orientation_anisotropy.amplitude", f.orientation_anisotropy().amplitude(), 0, 0.9, true});
    checks.push_back({"friction.orientation_anisotropy.period_deg", f.orientation_anisotropy().period_deg(), 0, 360, false});
  }
  if (f.direction_asymmetry().enabled()) {
    checks.push_back({"friction.direction_asymmetry.ratio", f.direction_asymmetry().ratio(), -0.9, 0.9, true});
  }
  if (f.presliding_hysteresis().enabled()) {
    checks.push_back({"friction.presliding_hysteresis.elements", static_cast<double>(f.presliding_hysteresis().elements()),
                      2, kMaxSlipElements, true});
    checks.push_back({"friction.presliding_hysteresis.spread", f.presliding_hysteresis().spread(), 0, 0.95, false});
    checks.push_back({"friction.presliding_hysteresis.breakaway_ratio", f.presliding_hysteresis().breakaway_ratio(),
                      0, 0.99, true});
  }
  if (f.rate_state().enabled()) {
    checks.push_back({"friction.rate_state.direct_coeff", f.rate_state().direct_coeff(), 0, 1, true});
    checks.push_back({"friction.rate_state.state_coeff", f.rate_state().state_coeff(), 0, 1, true});
    checks.push_back({"friction.rate_state.reference_velocity_m_per_s", f.rate_state().reference_velocity_m_per_s(),
                      1e-12, 1, true});
    checks.push_back({"friction.rate_state.memory_length_m", f.rate_state().memory_length_m(), 1e-12, 1e-3, true});
    checks.push_back({"friction.rate_state.initial_state_s", f.rate_state().initial_state_s(), 1e-9, 1e9, true});
    if (f.rate_state().direct_effect_rate() == v1::RATE_STATE_DIRECT_SLIP_RATE && f.presliding_hysteresis().enabled()) {
      return std::string("sim.friction.rate_state.direct_effect_rate = RATE_STATE_DIRECT_SLIP_RATE: needs "
                         "sim.friction.presliding_hysteresis.enabled = false (the slip rate is solved for one bristle)");
    }
  }
  return first_failure(checks);
}

std::optional<std::string> validate_tip_and_sample(const v1::SimConfig& c) {
  std::vector<Check> checks = {
      {"sample.slope_deg", std::fabs(c.sample().slope_deg()), 0, 30, true},
      {"sample.rotation_deg", std::fabs(c.sample().rotation_deg()), 0, 360, true},
  };
  if (c.tip().tilt_offset().enabled()) {
    checks.push_back({"tip.tilt_offset.angle_deg", std::fabs(c.tip().tilt_offset().angle_deg()), 0, 30, true});
  }
  const auto& b = c.tip().backlash();
  if (b.enabled()) {
    checks.push_back({"tip.backlash.width_m", b.width_m(), 0, 1e-5, true});
    checks.push_back({"tip.backlash.tip_mass_kg", b.tip_mass_kg(), 0, 0.9 * c.lateral().moving_mass_kg(), false});
    checks.push_back({"tip.backlash.coupling_stiffness_n_per_m", b.coupling_stiffness_n_per_m(), 0, 1e9, false});
    checks.push_back({"tip.backlash.coupling_damping_n_s_per_m", b.coupling_damping_n_s_per_m(), 0, 1e6, true});
  }
  const auto& d = c.sample().drift();
  if (d.enabled()) {
    checks.push_back({"sample.drift.rate_m_per_s", std::fabs(d.rate_m_per_s()), 0, 1e-6, true});
    checks.push_back({"sample.drift.velocity_rms_m_per_s", d.velocity_rms_m_per_s(), 0, 1e-6, true});
    checks.push_back({"sample.drift.correlation_time_s", d.correlation_time_s(), 0, 1e6, false});
  }
  const auto& w = c.sample().wear();
  if (w.enabled()) {
    checks.push_back({"sample.wear.steady_state_ratio", w.steady_state_ratio(), 0.05, 2, true});
    checks.push_back({"sample.wear.decay_per_pass", w.decay_per_pass(), 0, 100, true});
    checks.push_back({"sample.wear.reference_load_n", w.reference_load_n(), 0, 1, false});
    checks.push_back({"sample.wear.load_exponent", w.load_exponent(), -3, 3, true});
    checks.push_back({"sample.wear.bin_width_m", w.bin_width_m(), 1e-9, 1e-5, true});
  }
  if (c.sample().heterogeneity().enabled()) {
    checks.push_back({"sample.heterogeneity.rms", c.sample().heterogeneity().rms(), 0, 0.3, true});
  }
  return first_failure(checks);
}

}  // namespace

std::optional<std::string> validate_sim_config(const v1::SimConfig& c) {
  if (auto e = validate_lateral(c.lateral())) return e;
  if (auto e = validate_normal(c.normal())) return e;
  if (auto e = validate_friction(c.friction())) return e;
  if (auto e = validate_tip_and_sample(c)) return e;
  const auto& s = c.sensors();
  return first_failure({
      {"sensors.lateral_force_noise_n", s.lateral_force_noise_n(), 0, 1e-3, true},
      {"sensors.lateral_force_resolution_n", s.lateral_force_resolution_n(), 0, 1e-3, true},
      {"sensors.normal_force_noise_n", s.normal_force_noise_n(), 0, 1e-3, true},
      {"sensors.normal_force_resolution_n", s.normal_force_resolution_n(), 0, 1e-3, true},
      {"sensors.normal_displacement_noise_m", s.normal_displacement_noise_m(), 0, 1e-6, true},
      {"sensors.normal_displacement_resolution_m", s.normal_displacement_resolution_m(), 0, 1e-6, true},
      {"sensors.normal_displacement_drift_m_per_s", std::fabs(s.normal_displacement_drift_m_per_s()), 0, 1e-6, true},
      {"sensors.lateral_position_record_noise_m", s.lateral_position_record_noise_m(), 0, 1e-6, true},
      {"integrator.max_h_lambda", c.integrator().max_h_lambda(), 0,
       c.integrator().method() == v1::INTEGRATION_RK4 ? 2.5 : 1.8, false},
      {"integrator.max_substeps", static_cast<double>(c.integrator().max_substeps()), 1, 1e5, true},
      {"integrator.contact_law_tolerance_n", c.integrator().contact_law_tolerance_n(), 0, 1e-6, true},
  });
}

}  // namespace tribo::sim
