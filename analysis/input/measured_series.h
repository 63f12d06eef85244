// A measured friction run as the identification sees it: one row per sample,
// SI units (the force channel may be a stress, Pa, for shear-stress data; the
// unit is carried along and used in the report). The force is the one the
// friction model must explain: the measured lateral (friction) force, or a
// drive force that also accelerates a mass (EMPS), see fit_mass in
// analysis/models/friction_model.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tribo::analysis {

// A motion estimate of the record as the base model's held-out force error
// weighs it (tribo-fit --motion-estimator auto: weigh_motion_estimates in
// analysis/diagnosis.h).
struct MotionModelEvidence {
  std::string estimator;
  double heldout_pass_rms = 0;        // force units, over the held-out pass samples
  std::size_t heldout_samples = 0;    // those samples (the same for every estimate weighed)
  bool state_from_rest = false;       // the pass start whose base fit gave it
  std::map<int, double> block_sse;    // that fit's squared error summed per held-out pass
  // Its held-out mean squared error above the chosen one's, in standard
  // errors of the difference over the held-out passes (0 for the chosen).
  double heldout_excess_se = 0;
  bool chosen = false;
};

struct MeasuredSeries {
  std::string source;        // file or run directory, for the report
  std::string force_unit = "N";
  std::vector<double> time_s;
  std::vector<double> position_m;             // measured, or the smoother's estimate (derive_motion_smoothed)
  std::vector<double> velocity_m_per_s;       // measured, or derived by derive_motion()
  std::vector<double> acceleration_m_per_s2;  // measured, or derived by derive_motion()
  std::vector<double> force_n;
  std::vector<double> normal_force_n;         // empty: no normal-load channel
  std::vector<double> reference_m;            // commanded position; empty: none
  std::vector<std::uint32_t> segment;         // protocol segment (tribo runs); empty otherwise
  bool velocity_measured = false;
  bool acceleration_measured = false;
  // How the velocity and acceleration were obtained where not measured, and
  // the position noise floor estimated from the record (analysis/motion/motion_estimate.h).
  std::string motion_estimator = "none";
  double position_noise_m = 0;        // white position noise (RMS), from third differences
  double position_resolution_m = 0;   // smallest position step (0: none seen)
  double velocity_noise_m_per_s = 0;  // the estimator's velocity standard deviation (median)
  int velocity_jumps = 0;             // where the smoother let the velocity jump (speed steps, break-aways)
  int velocity_jumps_force_did_not_follow = 0;  // jumps the test found that the force did not follow (not taken)
  int loop_taps = 0;                  // motion from the reference: taps of the fitted loop response (0: not used)
  double loop_variance_explained = 0;
  int loop_force_taps = 0;                 // ... and of the force's (0: not used)
  double loop_force_response_m_per_n = 0;  // the force taps' sum
  std::vector<MotionModelEvidence> motion_evidence;  // the estimates weighed (--motion-estimator auto); else empty

  std::size_t size() const { return time_s.size(); }
  bool has_normal() const { return !normal_force_n.empty(); }
};

// Fills velocity and acceleration where they were not measured: central
// differences of the position (and then of the velocity), after a centred
// moving average over smoothing_s (0: none). Non-uniform sampling is fine.
void derive_motion(MeasuredSeries& series, double smoothing_s);

// Fills velocity and acceleration where they were not measured with the
// Rauch-Tung-Striebel smoother of analysis/motion/motion_estimate.h (noise floor and
// motion-model intensity estimated from the record), and records the
// position noise floor and the estimator in any case.
// When the velocity is derived, the position becomes the smoother's estimate
// too, in place of the record's own (nothing after the estimate reads that):
// the model's bristle is driven by position increments, and raw increments
// carry the full position noise (10 nm at 500 Hz is 5 um/s).
// loop_normal_matrix: the loop model's matrix as loop_normal_matrix()
// (analysis/motion/motion_estimate.h) formed it for this series, or null.
// With a reference, the motion model: the loop model
// (estimate_motion_with_reference) or the smoother with an intensity per
// stretch of the setpoint (estimate_motion_by_stretches; there loop_force and
// velocity_jumps are not used).
enum class ReferenceMotion { loop_model, setpoint_stretches };
void derive_motion_smoothed(MeasuredSeries& series, bool loop_force = false, bool velocity_jumps = false,
                            const Eigen::MatrixXd* loop_normal_matrix = nullptr,
                            ReferenceMotion reference_motion = ReferenceMotion::loop_model);

// Keeps only what the motion estimate gave (position, velocity, acceleration
// and the estimator's figures): another estimate of a series' motion, kept
// beside that series without a second copy of its other columns.
void keep_motion_only(MeasuredSeries& series);

// The series' time, force and normal load with the position, velocity and
// acceleration of motion (a keep_motion_only() estimate of the same samples):
// what a model is fitted to; without the reference and segment columns,
// which only the motion estimate and segmentation read.
MeasuredSeries with_motion_of(const MeasuredSeries& series, const MeasuredSeries& motion);

// The samples [first, last) as a new series (for slicing long recordings).
MeasuredSeries slice(const MeasuredSeries& series, std::size_t first, std::size_t last);

// Empty when the series is usable: equal channel lengths, at least 16 samples,
// strictly increasing time, finite values.
std::string check_series(const MeasuredSeries& series);

}  // namespace tribo::analysis
