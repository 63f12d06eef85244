// Preprocessing and identification metrics of a recorded scratch, after the
// dissertation (Srivastava 2006, §3.3, §5.3 and Table 5.1):
//   - tilt correction (§3.3.2): the slope of the normal displacement against
//     the lateral position over a window where the normal force is constant
//     and the tip moves, subtracted from the whole depth trace;
//   - lateral-force drift from holds (§3.3.3): the force's rate of change
//     while the tip rests, hold by hold;
//   - per loaded sliding segment: stretch time ts (motion command to slip, at
//     the stiction peak) and stretch distance ds (measured travel until then)
//     beside run_metrics' stiction peak Fs and steady lag dl, and the Table 5.1
//     gains sigma = Fs/ds (eq. 26), mki = 2 Fs/(v0 ts^2) (eq. 28),
//     mk = mki dl/v0 (eq. 33).
// SI units throughout (Table 5.1 is in µm, µN, s: convert at the edges).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/metrics/run_metrics.h"
#include "tribo/v1/api.pb.h"

namespace tribo::analysis {

struct TiltFit {
  std::uint32_t segment = 0;      // the window the slope was fitted on
  double slope = 0;               // d(normal displacement) / d(lateral position)
  double intercept_m = 0;
  std::size_t samples = 0;
};

// The first segment whose normal setpoint is constant and whose lateral
// setpoint moves (the approach of the standard scratch), or nullopt.
std::optional<TiltFit> fit_surface_tilt(const v1::SampleBlock& samples);

// Normal displacement minus the fitted plane, for every sample.
std::vector<double> tilt_corrected_depth(const v1::SampleBlock& samples, const TiltFit& tilt);

struct HoldDrift {
  std::uint32_t segment = 0;
  double duration_s = 0;
  double rate_n_per_s = 0;        // slope of the lateral force in time
  double rate_std_error = 0;
};

struct DriftFromHolds {
  std::vector<HoldDrift> holds;   // loaded holds (lateral setpoint constant, normal setpoint > 0)
  double mean_rate_n_per_s = 0;   // duration-weighted
};

DriftFromHolds lateral_drift_from_holds(const v1::SampleBlock& samples);

struct Table51Gains {
  double contact_stiffness_n_per_m = 0;  // sigma = Fs / ds            (eq. 26)
  double integral_gain = 0;              // mki = 2 Fs / (v0 ts^2), N/(m s) (eq. 28)
  double proportional_gain = 0;          // mk = mki dl / v0, N/m     (eq. 33)
};

Table51Gains table51_gains(double stiction_n, double stretch_time_s, double stretch_distance_m, double lag_m,
                           double velocity_m_per_s);

struct ScratchIdentification {
  SlidingSegmentMetrics metrics;  // mean friction, mu, stiction peak and time, steady lag
  double stretch_time_s = 0;      // = metrics.stiction_time_s
  double stretch_distance_m = 0;  // measured travel from segment start to the stiction peak
  Table51Gains gains;
};

std::vector<ScratchIdentification> scratch_identification(const v1::SampleBlock& samples);

// What a loaded sliding segment actually did, beside what was commanded: the
// tip's measured velocity (least-squares slope of the measured position over
// the steady window), the travel, and whether the window was a steady state.
// Steady means: at least kMinSteadySamples samples, the measured velocity
// within kSteadyVelocityTolerance of the commanded one, and a positive mean
// friction; otherwise why_not says which failed, with the numbers.
inline constexpr std::uint64_t kMinSteadySamples = 100;
inline constexpr double kSteadyVelocityTolerance = 0.10;  // relative

struct SlidingCheck {
  double measured_velocity_m_per_s = 0;
  double commanded_travel_m = 0;  // setpoint change over the segment
  double measured_travel_m = 0;   // position change over the segment
  bool steady = false;
  std::string why_not;            // empty when steady
  bool stiction_peak_found = false;  // a peak above the steady mean friction
};

SlidingCheck check_sliding(const v1::SampleBlock& samples, const SlidingSegmentMetrics& metrics);

// A lateral oscillation (a SINE segment): the lateral setpoint reverses
// direction at least twice. Its frequency is the setpoint's (whole cycles:
// reversals / 2 over the segment), and amplitudes and phases come from a
// least-squares fit of offset + drift + a sin + b cos at that frequency to the
// setpoint, the measured position and the friction (lateral) force.
struct OscillationMetrics {
  std::uint32_t segment = 0;
  double begin_s = 0, end_s = 0;
  double frequency_hz = 0;
  double cycles = 0;
  std::uint64_t samples = 0;
  double normal_force_n = 0;            // mean measured
  double setpoint_amplitude_m = 0;
  double position_amplitude_m = 0;
  double position_phase_deg = 0;        // of the position against the setpoint; negative: lags
  double force_amplitude_n = 0;
  double force_phase_deg = 0;           // of the lateral force against the measured position
};

// The segments whose lateral setpoint oscillates, in order.
std::vector<OscillationMetrics> oscillation_metrics(const v1::SampleBlock& samples);

// True if the segment's lateral setpoint reverses direction at least twice.
bool is_oscillation_segment(const v1::SampleBlock& samples, std::uint32_t segment);

}  // namespace tribo::analysis
