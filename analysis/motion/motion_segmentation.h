// Cuts a measured run into holds (the tip at rest) and passes (motion in one
// direction, from a reversal or a motion onset to the next), labels every
// sample with what the residual signatures look at (direction, distance and
// time since the pass began, the dwell before it), and assigns whole passes
// to the fit or the held-out set, alternating in time within each condition
// (direction, load level, speed level; the alternation shifted between
// conditions), so that held-out error is measured on segments the fit has not
// seen, under every condition, and never on random samples.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "analysis/input/measured_series.h"

namespace tribo::analysis {

struct SegmentationOptions {
  // A hold: |v| below max(hold_speed_fraction * 95th-percentile speed, 3 x the
  // velocity noise) for at least min_hold_s (0: max(0.05 s, 20 samples)).
  double hold_speed_fraction = 0.02;
  double min_hold_s = 0;
  // Tribo runs (reference_m is the lateral setpoint): holds, directions and
  // pass boundaries from the setpoint instead, which stands exactly still in
  // a hold, while the tip settles at nm/s for a second after each stop. Not
  // for a CSV's --reference, which may be any commanded signal.
  bool segment_by_reference = false;
  // A reversal: the position retreats from its running extreme by more than
  // max(reversal_fraction * range of x, 5 x the position noise).
  double reversal_fraction = 1e-3;
  // Fewer held-out passes than this: fall back to alternating time chunks.
  int min_heldout_passes = 2;
  int fallback_chunks = 8;
};

struct Pass {
  std::size_t first = 0, last = 0;  // inclusive sample range
  int direction = 0;                // +1 or -1
  bool after_hold = false;          // the pass starts from rest (motion onset), not a reversal
  double dwell_before_s = 0;        // duration of that hold
  double median_speed_m_per_s = 0;
  double mean_normal_n = 0;         // 0 without a normal channel
  int speed_level = 0;              // passes with similar median speed share a level
  int load_level = 0;
  bool heldout = false;
};

struct Hold {
  std::size_t first = 0, last = 0;
};

struct MotionSegmentation {
  std::vector<int> direction;                 // per sample: +1, -1, 0 in holds
  std::vector<int> pass_of;                   // per sample: pass index, -1 in holds
  std::vector<double> distance_since_start_m; // since the pass began (0 in holds)
  // (Per-sample time since the pass began and dwell before it were dropped:
  // nothing read them, and they were 16 of the diagnosis' bytes per sample.
  // Each Pass carries its dwell_before_s.)
  std::vector<char> heldout;                  // per sample: 1 held out, 0 fit
  std::vector<int> block_of;                  // per sample: held-out block (pass or chunk)
  std::vector<Pass> passes;
  std::vector<Hold> holds;
  std::vector<double> speed_levels_m_per_s;   // representative speed per level
  std::vector<double> load_levels_n;          // representative load per level (empty: none)
  double hold_speed_m_per_s = 0;
  double smoothing_window_s = 0;              // of the velocity used to find holds and reversals
  double reversal_distance_m = 0;
  double position_noise_m = 0;
  std::string heldout_scheme;
  int block_count = 0;
};

MotionSegmentation segment_motion(const MeasuredSeries& series, const SegmentationOptions& options = {});

// Whether the passes go both ways (at least one each way), or all one way
// (velocity steps; false without passes).
bool slides_both_ways(const MotionSegmentation& m);
bool slides_one_way(const MotionSegmentation& m);

// The stretches between passes: the holds and what the segmentation leaves
// outside both (the load ramps of a protocol that changes the load at rest),
// as [first, last], each without margin_s at either end (the stop's and the
// start's transients); the ones left with fewer than min_samples dropped.
std::vector<Hold> rest_stretches(const MeasuredSeries& series, const MotionSegmentation& m, double margin_s,
                                 std::size_t min_samples);

// Robust noise level of a sampled signal from its second differences
// (median absolute deviation), i.e. of the part that is white at the sample rate.
double white_noise_rms(const std::vector<double>& y);

}  // namespace tribo::analysis
