// Position, velocity and acceleration of the moving body estimated from a
// noisy position record, whatever its noise: a Rauch-Tung-Striebel smoother
// (forward Kalman filter, backward pass) with a constant-acceleration motion
// model driven by white jerk. Both noise intensities come from the record:
//   - the position noise floor from the third differences of the position
//     (white noise gives var = 20 sigma^2; a smooth motion almost nothing;
//     the median absolute value keeps onsets and turns out of it), never below
//     the position's resolution (its smallest step) / sqrt(12);
//   - the jerk intensity q by maximum likelihood of the filter's innovations
//     over a log grid, refined by golden section.
// Sampling may be non-uniform (the model is discretised per interval).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tribo::analysis {

struct MotionEstimate {
  std::string estimator;             // e.g. "rts_constant_acceleration"
  double position_noise_m = 0;       // estimated white position noise (RMS)
  double position_resolution_m = 0;  // smallest step of the position record (0: none seen)
  double jerk_intensity = 0;         // q of the motion model (m^2/s^5), maximum likelihood (by stretches: the samples' median)
  double velocity_std_m_per_s = 0;   // median smoothed velocity standard deviation
  // Samples i where the velocity was let jump from sample i - 1's (speed
  // steps, break-aways): found by a likelihood-ratio test (motion_estimate.cc).
  std::vector<std::size_t> velocity_jumps;
  // Jumps the test found that the force did not follow, not taken (with a force).
  int velocity_jumps_force_did_not_follow = 0;
  int loop_taps = 0;                 // with a reference: taps of the fitted loop response (0: none)
  int loop_force_taps = 0;           // with a reference and a force: taps of the force's response
  double loop_force_response_m_per_n = 0;  // the force taps' sum: position per newton of measured force
  double loop_variance_explained = 0;
  std::vector<double> position_m, velocity_m_per_s, acceleration_m_per_s2;
};

// Robust white-noise RMS of a sequence from its third differences (times
// assumed roughly uniform).
double third_difference_noise(const std::vector<double>& y);

// Smallest nonzero step between consecutive values (quantisation), or 0.
double resolution_of(const std::vector<double>& y);

// velocity_jumps: the velocity may also jump between two samples, where a
// generalised likelihood-ratio test finds it did (a drive that steps its
// speed within a sample interval: velocity-step tests); estimator
// "rts_constant_acceleration_with_velocity_jumps". Off, a step is followed
// by a jerk raised for the whole record. With the measured force (same
// samples), a jump is taken only where the force follows it: moves with it,
// the same sign, clear of its noise (a contact's direct effect); a jump the
// force does not see is the drive's position record, not the contact's slip.
MotionEstimate estimate_motion(const std::vector<double>& time_s, const std::vector<double>& position_m,
                               bool velocity_jumps = false, const std::vector<double>& force_n = {});

// With the commanded position: the closed loop's response to the reference
// (a linear impulse response over 0.2 s, fitted to the record by least
// squares, any loop order) and, if the measured friction force is given, the
// tip's yield to that force within three samples (a servo of finite
// stiffness) carry the fast motion (onsets, stops, the yield at a reversal),
// and the smoother above estimates only what the loop model leaves (tracking
// errors from friction, model mismatch), whose jerk is small. Falls back to
// estimate_motion() when the loop model explains less than 90 % of the
// position's variance, or the sampling is not uniform.
// The setpoint's stretches: holds, passes at one speed, ramps; the sample
// index at which each starts (0 first). A stretch ends where the setpoint's
// slope changes by more than 2 % of itself plus 0.1 % of the record's
// steepest slope.
std::vector<std::size_t> setpoint_stretches(const std::vector<double>& time_s, const std::vector<double>& reference_m);

// The smoother above with a jerk intensity of its own, by maximum
// likelihood, for each stretch of the setpoint of at least 50 samples (the
// shorter ones, where the slope keeps changing, share one, fitted with the
// others held): a servo that holds still, moves at a steady speed and
// changes speed has a different motion's roughness in each, which one
// intensity for the record blurs (it rounds the onsets off into the holds
// and the passes). The setpoint serves only to cut the record:
// no loop model enters the motion. Estimator
// "rts_constant_acceleration_by_setpoint_stretches".
MotionEstimate estimate_motion_by_stretches(const std::vector<double>& time_s, const std::vector<double>& position_m,
                                            const std::vector<double>& reference_m);

// normal_matrix: the loop model's normal-equation matrix with the force
// taps, as loop_normal_matrix() forms it, or null (formed here).
MotionEstimate estimate_motion_with_reference(const std::vector<double>& time_s, const std::vector<double>& position_m,
                                              const std::vector<double>& reference_m,
                                              const std::vector<double>& force_n = {}, bool velocity_jumps = false,
                                              const std::vector<double>& force_for_jumps = {},
                                              const Eigen::MatrixXd* normal_matrix = nullptr);

// The normal-equation matrix of the loop model above with the force taps,
// on `threads` cores (0: one per core): formed once, it serves both of the
// diagnosis' loop models (with and without the force: the latter's matrix is
// its reference-and-constant part, the same sums); nullopt where
// estimate_motion_with_reference() fits no loop model (a short record,
// non-uniform sampling, no force).
std::optional<Eigen::MatrixXd> loop_normal_matrix(const std::vector<double>& time_s, const std::vector<double>& reference_m,
                                                  const std::vector<double>& force_n, unsigned threads);

}  // namespace tribo::analysis
