// The simulated instrument: normal axis, lateral drive, lateral plant with
// its friction, sample and sensors composed and stepped once per controller
// tick. The controller never sees InstrumentTruth; it reads only the
// Measurement, as it would from real hardware.
//
// One tick, in order: the normal axis settles under the commanded force (its
// electrostatic law at the previous tick's plate position); the drive
// electronics turn the lateral force command into plate voltages at the last
// measured position; the contact's friction levels follow from the load,
// sample orientation and wear; the lateral plant is integrated over the tick
// (sim/step_size.h picks the sub-steps and the scheme); the slow states (wear
// track, sample creep) advance; the sensors are sampled.
#pragma once

#include <cstdint>

#include "sim/capacitive_sensor.h"
#include "sim/electrostatic_drive.h"
#include "sim/friction_effects.h"
#include "sim/gauss_markov.h"
#include "sim/lateral_plant.h"
#include "sim/noise_source.h"
#include "sim/normal_axis.h"
#include "sim/sensor_model.h"
#include "sim/step_size.h"
#include "sim/wear_track.h"

namespace tribo::sim {

// Tip tilt (§5.2): a lateral force N tan(angle) on the tip, towards +x.
struct TiltParams {
  bool enabled = false;
  double angle_rad = 0;
};

// Lateral-force drift (§3.3.3): the sample creeps under the tip with
// v_sample = rate + n(t), n a first-order Gauss-Markov process.
struct SampleDriftParams {
  bool enabled = false;
  double rate_m_per_s = 0;
  double velocity_rms_m_per_s = 0;
  double correlation_time_s = 1;
};

// Run-to-run variation of the scratched spot: levels times 1 + rms w, w a
// standard normal drawn once from the run's seed (clamped to stay positive).
struct HeterogeneityParams {
  bool enabled = false;
  double rms = 0;
};

struct SampleParams {
  double rotation_deg = 0;
  double slope_rad = 0;
  SampleDriftParams drift;
  WearParams wear;
  HeterogeneityParams heterogeneity;
};

struct InstrumentParams {
  LateralAxisParams lateral;
  double lateral_calibrated_spring_n_per_m = 0;
  ElectrostaticDriveParams lateral_drive;
  CapacitiveSensingParams lateral_sensing;
  NormalAxisParams normal;
  FrictionModel friction;
  TiltParams tilt;
  SampleParams sample;
  SensorSpecs sensors;
  IntegratorSettings integrator;
};

// Actuator commands, held for one tick.
struct DriveInput {
  double normal_force_n = 0;
  double lateral_force_n = 0;
};

// What the sensors report at the end of a tick.
struct Measurement {
  double normal_force_n = 0;
  double normal_displacement_m = 0;
  double lateral_force_n = 0;
  double lateral_position_m = 0;
  // The lateral position before linearisation, for diagnostics.
  double lateral_sense_voltage_v = 0;
  std::int64_t lateral_adc_counts = 0;
  // The readout noise the record carries on top of lateral_position_m
  // (SensorSpecs::lateral_position_record_noise_m); the loop never sees it.
  double lateral_position_record_noise_m = 0;

  // The lateral position as the instrument records it.
  // (Without record noise exactly lateral_position_m: x + 0 would turn -0 into +0.)
  double recorded_lateral_position_m() const {
    return lateral_position_record_noise_m == 0 ? lateral_position_m
                                                : lateral_position_m + lateral_position_record_noise_m;
  }
};

// The true state, for tests and diagnostics only.
struct InstrumentTruth {
  LateralState lateral;
  NormalEquilibrium normal;
  FrictionLevels levels;
  double friction_n = 0;
  double drive_force_n = 0;  // the drive's true force on the plate at the end of the tick
  double tip_force_n = 0;    // tilt
  PlateVoltages voltages;    // at the end of the tick
  double dead_time_s = 0;    // a handover: only the bias acted for this long
  double sample_offset_m = 0;
  double sample_velocity_m_per_s = 0;
  double site_factor = 1;    // this run's spot on the sample (heterogeneity)
  bool snapped = false;      // the plate sits on a stop
  bool handover = false;     // no plate was driven during the tick
  double time_s = 0;
};

struct StepReport {
  int substeps = 0;
  int law_evaluations = 0;       // of S, by the held-contact scheme (sim/held_contact.h)
  bool split = false;            // the contact relaxation was integrated exactly
  bool substep_cap_hit = false;
  bool snapped = false;
  bool handover = false;
  bool retried = false;          // the integrator's safety net redid the tick
};

class SimInstrument {
 public:
  SimInstrument(const InstrumentParams& params, std::uint64_t seed);

  // Advances the plant by dt_s under drive, then samples the sensors.
  StepReport step(const DriveInput& drive, double dt_s);

  const Measurement& measurement() const { return measurement_; }
  // friction_n and drive_force_n are evaluated here, on the first read after
  // a step, not in every step: only tests and diagnostics read them, and they
  // cost ~6 % of a tick (bench/sim_bench.cc). Same state, same inputs: the
  // same values.
  const InstrumentTruth& truth() const {
    if (friction_stale_) {
      truth_.friction_n = lateral_derivative(plant_, inputs_, truth_.lateral).friction_n;
      truth_.drive_force_n = inputs_.drive.force_n(truth_.lateral.position_m);
      friction_stale_ = false;
    }
    return truth_;
  }
  const InstrumentParams& params() const { return params_; }
  const LateralPlant& plant() const { return plant_; }
  // The inputs the plant was held at during the last tick (after its dead
  // time, if any: truth().dead_time_s).
  const LateralInputs& last_inputs() const { return inputs_; }
  double tip_sample_position_m() const;

 private:
  void settle_normal_axis(double command_n);
  void sample_sensors(const DriveInput& drive, double dt_s);

  InstrumentParams params_;
  LateralPlant plant_;
  double tan_tilt_ = 0, tan_slope_ = 0;
  double hertz_coefficient_ = 0;  // of params_.normal, for the solve every tick
  mutable InstrumentTruth truth_;     // friction_n, drive_force_n filled in lazily by truth()
  mutable bool friction_stale_ = false;
  Measurement measurement_;
  LateralInputs inputs_;
  DriveElectronics electronics_;
  CapacitivePositionSensor lateral_sensor_;
  NoiseSource lateral_force_noise_;
  NoiseSource normal_force_noise_;
  NoiseSource normal_displacement_noise_;
  NoiseSource lateral_position_record_noise_;
  FirstOrderGaussMarkov sample_creep_;
  WearTrack wear_;
  HeldContactMemory held_contact_;  // the held-contact scheme's estimate of S's change
  double settled_force_n_ = 0, settled_surface_m_ = 0;
};

}  // namespace tribo::sim
