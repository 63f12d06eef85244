// What `tribo-fit metrics` and `tribo-fit diagnose` compute, as functions, so
// that the command line and the Python module (client/python/native) give the
// same report for the same input.
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "analysis/diagnosis.h"
#include "analysis/effects/effect.h"
#include "analysis/input/measured_series.h"
#include "tribo/v1/api.pb.h"

namespace tribo::analysis {

// `tribo-fit metrics RUN_DIR --json`: scratch metrics, hold drift and tilt (SI).
std::string metrics_json(const v1::SampleBlock& samples);

struct DiagnoseRequest {
  std::vector<Effect> candidates{kAllEffects.begin(), kAllEffects.end()};
  double begin_s = -HUGE_VAL, end_s = HUGE_VAL;  // the time window analysed
  bool fit_mass = false;
  bool load_scaling = true;       // friction levels proportional to the normal load, when given
  double stribeck_exponent = 1;
  double smooth_s = 0;            // > 0: central differences after this smoothing window
  bool central_differences = false;  // instead of the smoother with the record's noise floor
  bool loop_force = false;           // the reference loop's model also driven by the measured force
  bool velocity_jumps = false;       // the smoother may let the velocity jump (speed steps within a sample)
  ReferenceMotion reference_motion = ReferenceMotion::loop_model;  // with a reference: the motion model (derive_motion_smoothed)
  // With a reference: the loop model (without the force) and the setpoint's
  // stretches both estimated, and the one under which the base fit predicts
  // the held-out force better kept (weigh_motion_estimates,
  // analysis/diagnosis.h); reference_motion and loop_force are then not used.
  bool motion_by_heldout_force = false;
  // A tribo run directory: holds, directions and passes from the setpoint;
  // each pass starts from the force measured at rest (the loop's dither
  // relaxes the contact in holds in a way the record cannot show).
  bool tribo_run = false;
  DitherTerm dither = DitherTerm::off;  // --dither (DiagnosisOptions::dither)
  bool choose_base_contact = false;  // --base-model choose (DiagnosisOptions::choose_base_contact)
  double min_confusion_z = 0;        // --min-confusion-z (DiagnosisOptions::min_confusion_z)
  std::string command_line;       // recorded in the report
  PhaseTimings* timings = nullptr;   // --timings: each phase's time and work; none: null
};

struct DiagnoseOutcome {
  MeasuredSeries series;  // windowed, with the motion estimate
  Diagnosis diagnosis;
  std::string json;       // `tribo-fit diagnose --json`
  std::string error;      // non-empty: nothing else is set
};

// Windows the series, estimates the motion, diagnoses and reports.
DiagnoseOutcome diagnose_series(MeasuredSeries series, const DiagnoseRequest& request);

}  // namespace tribo::analysis
