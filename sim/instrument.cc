#include "sim/instrument.h"

#include <algorithm>
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
  kSampleSite = 7,
  kLateralPositionRecord = 8,
};

}  // namespace

SimInstrument::SimInstrument(const InstrumentParams& params, std::uint64_t seed)
    : params_(params),
      plant_{params.lateral, params.friction},
      tan_tilt_(params.tilt.enabled ? std::tan(params.tilt.angle_rad) : 0.0),
      tan_slope_(std::tan(params.sample.slope_rad)),
      hertz_coefficient_(hertz_coefficient(params.normal)),
      electronics_(params.lateral_drive),
      lateral_sensor_(params.lateral_sensing, derive_seed(seed, kLateralPositionWhite),
                      derive_seed(seed, kLateralPositionLowFrequency)),
      lateral_force_noise_(derive_seed(seed, kLateralForceNoise)),
      normal_force_noise_(derive_seed(seed, kNormalForceNoise)),
      normal_displacement_noise_(derive_seed(seed, kNormalDisplacementNoise)),
      lateral_position_record_noise_(derive_seed(seed, kLateralPositionRecord)),
      sample_creep_(params.sample.drift.enabled ? params.sample.drift.velocity_rms_m_per_s : 0.0,
                    params.sample.drift.correlation_time_s, derive_seed(seed, kSampleCreep)),
      wear_(params.sample.wear) {
  if (params_.sample.drift.enabled) {
    truth_.sample_velocity_m_per_s = params_.sample.drift.rate_m_per_s + sample_creep_.value();
  }
  if (params_.sample.heterogeneity.enabled) {
    NoiseSource site(derive_seed(seed, kSampleSite));
    truth_.site_factor = std::max(0.1, 1.0 + params_.sample.heterogeneity.rms * site.gaussian());
  }
  truth_.lateral.rate_state_s = params_.friction.rate_state.initial_state_s;
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
    truth_.normal = solve_normal_equilibrium(params_.normal, hertz_coefficient_, force, surface, truth_.normal.depth_m);
    settled_force_n_ = force;
    settled_surface_m_ = surface;
  }
}

StepReport SimInstrument::step(const DriveInput& drive, double dt_s) {
  settle_normal_axis(drive.normal_force_n);
  const double load = truth_.normal.contact_load_n;

  DriveField dead_field;
  truth_.dead_time_s = 0;
  if (params_.lateral_drive.enabled) {
    const DriveOutput out = electronics_.command(drive.lateral_force_n, measurement_.lateral_position_m, dt_s);
    truth_.dead_time_s = out.dead_time_s;
    truth_.voltages = out.dead_time_s < dt_s ? out.voltages : out.bias;
    dead_field = electrostatic_drive_field(params_.lateral_drive, out.bias);
    inputs_.drive = electrostatic_drive_field(params_.lateral_drive, out.voltages);
  } else {
    inputs_.drive = ideal_drive_field(drive.lateral_force_n);
  }
  truth_.handover = truth_.dead_time_s > 0;

  LateralState& lateral = truth_.lateral;
  const double sample_x_before = tip_sample_position_m();
  inputs_.levels = contact_levels(params_.friction, load, params_.sample.rotation_deg,
                                  truth_.site_factor * wear_.factor_at(sample_x_before));
  if (!inputs_.levels.in_contact()) {  // lifted off: the contact lets go and forgets
    lateral.bristle_m = 0;
    lateral.slip_m = {};
    lateral.contact_age_s = 0;
    lateral.rate_state_s = params_.friction.rate_state.initial_state_s;
    held_contact_ = {};
  }
  inputs_.tip_force_n = load * tan_tilt_;
  inputs_.sample_velocity_m_per_s = truth_.sample_velocity_m_per_s;
  inputs_.sample_offset_m = truth_.sample_offset_m;
  // S at the tick's start: the first evaluation of the step reuses it.
  const double stribeck_now =
      stribeck_at_tick_start(plant_, inputs_, lateral, held_contact_);

  // A handover first integrates its dead interval under the bias alone.
  AdvanceReport report;
  if (truth_.dead_time_s > 0) {
    LateralInputs dead = inputs_;
    dead.drive = dead_field;
    report = advance_lateral(plant_, dead, params_.integrator, truth_.dead_time_s, lateral, &stribeck_now,
                             &held_contact_);
  }
  if (truth_.dead_time_s < dt_s) {
    const AdvanceReport rest = advance_lateral(plant_, inputs_, params_.integrator, dt_s - truth_.dead_time_s, lateral,
                                               truth_.dead_time_s > 0 ? nullptr : &stribeck_now, &held_contact_);
    report = AdvanceReport{report.substeps + rest.substeps, report.law_evaluations + rest.law_evaluations,
                           report.split || rest.split, report.capped || rest.capped,
                           report.stopped || rest.stopped, report.retried || rest.retried};
  } else {
    inputs_.drive = dead_field;
  }
  const bool stopped = report.stopped;

  truth_.levels = inputs_.levels;
  friction_stale_ = true;  // truth() evaluates friction_n and drive_force_n when asked
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
  return StepReport{report.substeps, report.law_evaluations, report.split, report.capped, stopped, truth_.handover,
                    report.retried};
}

void SimInstrument::sample_sensors(const DriveInput& drive, double dt_s) {
  const SensorSpecs& s = params_.sensors;
  const CapacitivePositionSensor::Reading x =
      lateral_sensor_.sample(truth_.lateral.position_m, truth_.time_s, dt_s);
  measurement_.lateral_position_m = x.position_m;
  measurement_.lateral_sense_voltage_v = x.voltage_v;
  measurement_.lateral_adc_counts = x.counts;
  // Drawn only when configured: a config without it keeps its samples bit-identical.
  if (s.lateral_position_record_noise_m > 0) {
    measurement_.lateral_position_record_noise_m =
        s.lateral_position_record_noise_m * lateral_position_record_noise_.gaussian();
  }
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
