// The dissertation's experiments, run on the simulated instrument through
// the daemon's controller in lock-step (no I/O), as the instrument would
// record them: measured lateral force, position and normal force every tick.
//
// Every experiment starts the same way: approach 0 -> +2 um unloaded in
// 0.3 s, settle until 1.5 s, load over 0.5 s, rest, then move the position
// setpoint. Forces are tilt-corrected as §5.2 prescribes (friction = measured
// lateral force + N tan(theta) when moving towards +x).
#pragma once

#include <cstdint>
#include <vector>

#include "tribo/v1/daemon_config.pb.h"

namespace tribo::scorecard {

// Fig. 5.14's quantities of one static-to-kinetic transition (Table 5.1).
struct Breakaway {
  double peak_n = 0;           // Fs: the stiction peak (or the end of the rise, if no peak)
  bool spike = false;          // the force fell >= 2 % below the peak afterwards
  double time_to_peak_s = 0;   // ts, from motion onset
  double stretch_m = 0;        // ds: measured position change from onset to the peak
  double lag_m = 0;            // dl: setpoint - measured position in steady sliding
  double steady_n = 0;         // mean friction over the last 30 % of the motion
  double overshoot = 0;        // peak measured velocity / commanded velocity
  double peak_acceleration_m_per_s2 = 0;
};

struct BreakawayProtocol {
  double load_n = 9810e-6;
  double velocity_m_per_s = 18e-6;
  double rest_s = 2.0;
  double travel_m = 10e-6;
  double max_motion_s = 8.0;
};

Breakaway run_breakaway(const v1::DaemonConfig& config, const BreakawayProtocol& p, std::uint64_t seed);

// Forward and backward passes (§4.4): friction (F+ - F-)/2, tilt offset
// (F+ + F-)/2 from the raw measured force, and the true Hertz depth.
struct Passes {
  double load_n = 0;  // measured
  double friction_n = 0;
  double offset_n = 0;
  double depth_m = 0;
};

Passes run_passes(const v1::DaemonConfig& config, double load_n, double velocity_m_per_s, std::uint64_t seed);

// The tip held still under load (Fig. 3.12): peak-to-peak of the 1 s means
// of the measured lateral force over hold_s, after a 20 s settling.
double held_force_drift_n(const v1::DaemonConfig& config, double load_n, double hold_s, std::uint64_t seed);

// Steady friction (tilt-corrected, +x) at one velocity after a 2 s rest.
double steady_friction_n(const v1::DaemonConfig& config, double load_n, double velocity_m_per_s,
                         std::uint64_t seed);

}  // namespace tribo::scorecard
