#include "sim/instrument.h"

#include <cmath>

#include "sim/step_size.h"

namespace tribo::sim {

namespace {

// Stream ids of the noise sources; fixed forever so that a seed keeps
// meaning the same noise when sources are added.
enum NoiseStream : std::uint64_t {
  kLateralPositionWhite = 1,
  kLateralForceNoise = 2,
  kNormalForceNoise = 3,
  kNormalDisplacementNoise = 4,
  kLateralPositionLowFrequency = 5,
  kSampleCreep = 6,
};

}  // namespace

SimInstrument::SimInstrument(const InstrumentParams& params, std::uint64_t seed)
    : params_(params),
      plant_{params.lateral, params.friction},
      tan_tilt_(params.tilt.enabled ? std::tan(params.tilt.angle_rad) : 0.0),
      tan_slope_(std::tan(params.sample.slope_rad)),
      electronics_(params.lateral_drive),
      lateral_sensor_(params.lateral_sensing, derive_seed(seed, kLateralPositionWhite),
                      derive_seed(seed, kLateralPositionLowFrequency)),
      lateral_force_noise_(derive_seed(seed, kLateralForceNoise)),
      normal_force_noise_(derive_seed(seed, kNormalForceNoise)),
      normal_displacement_noise_(derive_seed(seed, kNormalDisplacementNoise)),
      sample_creep_(params.sample.drift.enabled ? params.sample.drift.velocity_rms_m_per_s : 0.0,
                    params.sample.drift.correlation_time_s, derive_seed(seed, kSampleCreep)),
      wear_(params.sample.wear) {
  if (params_.sample.drift.enabled) {
    truth_.sample_velocity_m_per_s = params_.sample.drift.rate_m_per_s + sample_creep_.value();
  }
  inputs_.drive = ideal_drive_field(0.0);
  sample_sensors(DriveInput{}, 0.0);
}

double SimInstrument::tip_sample_position_m() const {
  return tip_position_m(plant_, truth_.lateral) - truth_.sample_offset_m;
}

void SimInstrument::settle_normal_axis(double command_n) {
  const double force = normal_actuator_force_n(params_.normal, command_n,
                                               measurement_.normal_displacement_m,
                                               truth_.normal.displacement_m);
  const double surface = tip_sample_position_m() * tan_slope_;
  // Quasi-static: solve only when the force or the surface under the tip changed.
  if (force != settled_force_n_ || surface != settled_surface_m_ || truth_.time_s == 0) {
    truth_.normal = solve_normal_equilibrium(params_.normal, force, surface, truth_.normal.depth_m);
    settled_force_n_ = force;
    settled_surface_m_ = surface;
  }
}

StepReport SimInstrument::step(const DriveInput& drive, double dt_s) {
  settle_normal_axis(drive.normal_force_n);
  const double load = truth_.normal.contact_load_n;

  if (params_.lateral_drive.enabled) {
    truth_.voltages = electronics_.command(drive.lateral_force_n, measurement_.lateral_position_m, dt_s);
    truth_.handover = electronics_.in_handover();
    inputs_.drive = electrostatic_drive_field(params_.lateral_drive, truth_.voltages);
  } else {
    inputs_.drive = ideal_drive_field(drive.lateral_force_n);
  }

  LateralState& lateral = truth_.lateral;
  const double sample_x_before = tip_sample_position_m();
  inputs_.levels = contact_levels(params_.friction, load, params_.sample.rotation_deg,
                                  wear_.factor_at(sample_x_before));
  if (!inputs_.levels.in_contact()) {  // lifted off: the contact lets go and forgets
    lateral.bristle_m = 0;
    lateral.slip_m = {};
    lateral.contact_age_s = 0;
  }
  inputs_.tip_force_n = load * tan_tilt_;
  inputs_.sample_velocity_m_per_s = truth_.sample_velocity_m_per_s;
  inputs_.sample_offset_m = truth_.sample_offset_m;

  const LateralEvaluation now = lateral_derivative(plant_, inputs_, lateral);
  const LateralRates rates = lateral_rate_bounds(plant_, inputs_, lateral, now, dt_s);
  const StepPlan plan = plan_substeps(rates, dt_s, params_.integrator.max_h_lambda,
                                      params_.integrator.max_substeps);
  const bool stopped =
      plan.split ? integrate_lateral_split(plant_, inputs_, dt_s, plan.substeps, lateral)
                 : integrate_lateral(plant_, inputs_, dt_s, plan.substeps, lateral, &now.rate);
  if (!params_.lateral.backlash.enabled) {
    lateral.tip_position_m = lateral.position_m;
    lateral.tip_velocity_m_per_s = lateral.velocity_m_per_s;
  }

  truth_.levels = inputs_.levels;
  truth_.friction_n = lateral_derivative(plant_, inputs_, lateral).friction_n;
  truth_.drive_force_n = inputs_.drive.force_n(lateral.position_m);
  truth_.tip_force_n = inputs_.tip_force_n;
  truth_.snapped = stopped;
  truth_.time_s += dt_s;

  // Slow states, advanced once per tick.
  truth_.sample_offset_m += truth_.sample_velocity_m_per_s * dt_s;
  wear_.slide(sample_x_before, tip_sample_position_m(), load);
  if (params_.sample.drift.enabled) {
    truth_.sample_velocity_m_per_s = params_.sample.drift.rate_m_per_s + sample_creep_.advance(dt_s);
  }

  sample_sensors(drive, dt_s);
  return StepReport{plan.substeps, plan.split, plan.capped, stopped, truth_.handover};
}

void SimInstrument::sample_sensors(const DriveInput& drive, double dt_s) {
  const SensorSpecs& s = params_.sensors;
  const CapacitivePositionSensor::Reading x =
      lateral_sensor_.sample(truth_.lateral.position_m, truth_.time_s, dt_s);
  measurement_.lateral_position_m = x.position_m;
  measurement_.lateral_sense_voltage_v = x.voltage_v;
  measurement_.lateral_adc_counts = x.counts;
  // The transducer infers the force on the tip from what it believes its
  // drive applies and from its spring, both at the measured position.
  const double applied = params_.lateral_drive.enabled
                             ? electronics_.believed_force_n(truth_.voltages, x.position_m)
                             : drive.lateral_force_n;
  measurement_.lateral_force_n =
      measure(applied - params_.lateral_calibrated_spring_n_per_m * x.position_m, s.lateral_force_n,
              lateral_force_noise_);
  measurement_.normal_displacement_m =
      measure(truth_.normal.displacement_m + s.normal_displacement_drift_m_per_s * truth_.time_s,
              s.normal_displacement_m, normal_displacement_noise_);
  measurement_.normal_force_n =
      measure(reported_normal_force_n(params_.normal, drive.normal_force_n, measurement_.normal_displacement_m),
              s.normal_force_n, normal_force_noise_);
}

}  // namespace tribo::sim
