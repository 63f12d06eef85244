// Preprocessing and identification metrics of a recorded scratch, after the
// dissertation (physics.md §5, §6):
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
#include <vector>

#include "analysis/run_metrics.h"
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

}  // namespace tribo::analysis
