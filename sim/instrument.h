// The simulated instrument: lateral plant, normal axis and sensors composed and
// stepped once per controller tick. The controller never sees InstrumentTruth;
// it reads only the Measurement, as it would from real hardware.
#pragma once

#include <cstdint>

#include "sim/lateral_plant.h"
#include "sim/lugre_friction.h"
#include "sim/noise_source.h"
#include "sim/normal_contact.h"
#include "sim/sensor_model.h"

namespace tribo::sim {

struct IntegratorSettings {
  double max_h_lambda = 1.0;
  int max_substeps = 1000;
};

struct InstrumentParams {
  LateralAxisParams lateral;
  NormalAxisParams normal;
  LugreParams friction;
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
};

// The true state, for tests and diagnostics only.
struct InstrumentTruth {
  LateralState lateral;
  NormalEquilibrium normal;
  double friction_n = 0;
  double time_s = 0;
};

struct StepReport {
  int substeps = 0;
  bool split = false;            // the bristle relaxation was integrated exactly
  bool substep_cap_hit = false;
};

class SimInstrument {
 public:
  SimInstrument(const InstrumentParams& params, std::uint64_t seed);

  // Advances the plant by dt_s under drive, then samples the sensors.
  StepReport step(const DriveInput& drive, double dt_s);

  const Measurement& measurement() const { return measurement_; }
  const InstrumentTruth& truth() const { return truth_; }
  const InstrumentParams& params() const { return params_; }

 private:
  void sample_sensors(double drive_lateral_n);

  InstrumentParams params_;
  InstrumentTruth truth_;
  Measurement measurement_;
  NoiseSource lateral_position_noise_;
  NoiseSource lateral_force_noise_;
  NoiseSource normal_force_noise_;
  NoiseSource normal_displacement_noise_;
};

}  // namespace tribo::sim
