#include "sim/instrument.h"

#include "sim/step_size.h"

namespace tribo::sim {

namespace {

// Stream ids of the noise channels; fixed forever so that a seed keeps
// meaning the same noise when channels are added.
enum NoiseStream : std::uint64_t {
  kLateralPositionNoise = 1,
  kLateralForceNoise = 2,
  kNormalForceNoise = 3,
  kNormalDisplacementNoise = 4,
};

}  // namespace

SimInstrument::SimInstrument(const InstrumentParams& params, std::uint64_t seed)
    : params_(params),
      lateral_position_noise_(derive_seed(seed, kLateralPositionNoise)),
      lateral_force_noise_(derive_seed(seed, kLateralForceNoise)),
      normal_force_noise_(derive_seed(seed, kNormalForceNoise)),
      normal_displacement_noise_(derive_seed(seed, kNormalDisplacementNoise)) {
  sample_sensors(0.0);
}

StepReport SimInstrument::step(const DriveInput& drive, double dt_s) {
  truth_.normal = solve_normal_equilibrium(params_.normal, drive.normal_force_n);
  const FrictionLevels levels = friction_levels(params_.friction, truth_.normal.contact_load_n);
  LateralState& lateral = truth_.lateral;
  if (!levels.in_contact()) lateral.bristle_m = 0;  // lifted off: the bristles let go

  const LateralRates rates = lateral_rate_bounds(params_.lateral, params_.friction, levels, lateral,
                                                 drive.lateral_force_n, dt_s);
  const StepPlan plan = plan_substeps(rates, dt_s, params_.integrator.max_h_lambda,
                                      params_.integrator.max_substeps);
  if (plan.split) {
    integrate_lateral_split(params_.lateral, params_.friction, levels, drive.lateral_force_n, dt_s,
                            plan.substeps, lateral);
  } else {
    integrate_lateral(params_.lateral, params_.friction, levels, drive.lateral_force_n, dt_s,
                      plan.substeps, lateral);
  }
  truth_.friction_n =
      lugre_evaluate(params_.friction, levels, lateral.velocity_m_per_s, lateral.bristle_m).force_n;
  truth_.time_s += dt_s;
  sample_sensors(drive.lateral_force_n);
  return StepReport{plan.substeps, plan.split, plan.capped};
}

void SimInstrument::sample_sensors(double drive_lateral_n) {
  const SensorSpecs& s = params_.sensors;
  const double x = truth_.lateral.position_m;
  // The transducer infers the force on the tip from its drive and its spring.
  const double lateral_force = drive_lateral_n - params_.lateral.spring_n_per_m * x;
  measurement_.lateral_position_m = measure(x, s.lateral_position_m, lateral_position_noise_);
  measurement_.lateral_force_n = measure(lateral_force, s.lateral_force_n, lateral_force_noise_);
  measurement_.normal_force_n =
      measure(truth_.normal.contact_load_n, s.normal_force_n, normal_force_noise_);
  measurement_.normal_displacement_m =
      measure(truth_.normal.displacement_m, s.normal_displacement_m, normal_displacement_noise_);
}

}  // namespace tribo::sim
