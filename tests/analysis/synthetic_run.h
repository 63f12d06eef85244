// Synthetic friction runs for the diagnosis tests: a small forward model,
// written independently of analysis/ (its own integrator, its own form of
// each effect), driven by a prescribed tip motion like a tribo scratch series:
// loading ramps at rest, holds of several dwell times, passes back and forth
// at speeds over two decades and at three loads. Units as on the instrument
// (µm, µN) but stored in SI.
//
// Used where a known, noise-controlled truth in the analysis's own terms is
// the point: the fit's unit tests (parameter recovery, segmentation) and the
// benchmarks (bench/analysis_bench.cc, bench/lugre_fit_export.cc, runs of any
// length). The diagnosis itself is tested on runs of tribo's simulated
// instrument (tests/analysis/diagnosis_sim_test.cc).
#pragma once

#include <cstdint>

#include "analysis/input/measured_series.h"

namespace tribo::testing {

// Each effect in its own physical form; zero switches it off.
struct SyntheticEffects {
  double dwell_gain = 0;            // Fs after a long dwell: Fs (1 + gain); Armstrong's t/(t + dwell_time),
  double dwell_time_s = 2.0;        // t the contact age of Dieterich's ageing law: the time at rest,
  double dwell_memory_m = 0.5e-6;   // relaxing to D_c/|v| within a few D_c of sliding
  double lag_time_s = 0;            // Stribeck curve sees a first-order-lagged velocity
  double log_velocity = 0;          // mu multiplied by 1 + c ln(|v| / 1 µm/s)
  double load_exponent = 0;         // friction proportional to N^(1 + e) (e = -1/3: Hertz area)
  double periodic_amplitude = 0;    // mu multiplied by 1 + a sin(2 pi x / length)
  double periodic_length_m = 0.9e-6;
  double asymmetry = 0;             // mu multiplied by 1 + a sgn(v) (anisotropy)
  double tilt_tan = 0;              // lateral force reading + N tan(theta), also at rest
  double drift_n_per_s = 0;         // lateral force reading + a slow drift
  double breakaway_ratio = 0;       // elasto-plastic presliding (Dupont et al.)
  double backlash_gap_m = 0;        // play in series: the element is unloaded while the gap is open
  double extra_viscous_n_s_per_m = 0;  // on top of the contact's 0.5 N s/m (not an effect: the base has Fv)
};

struct SyntheticOptions {
  double rate_hz = 200;
  double force_noise_n = 2e-6;      // white, per sample
  double position_noise_m = 0.05e-9;
  bool three_loads = true;          // else one load (1 mN)
  int extra_loads = 0;              // more sweeps at 1.5, 0.75, 1.25 mN ... (longer runs, for benchmarks)
};

// A run with normal channel (N), lateral position and force; velocity and
// acceleration are derived by the caller (derive_motion) as for measured data.
analysis::MeasuredSeries synthetic_run(const SyntheticEffects& effects, std::uint64_t seed,
                                       const SyntheticOptions& options = {});

// The clean contact at one load (1 mN), its motion derived without smoothing
// as for measured data: the model's and the base fit's unit tests' scratch.
analysis::MeasuredSeries single_load_run(std::uint64_t seed);

}  // namespace tribo::testing
