// Fig. 5.14's quantities of one static-to-kinetic transition (Table 5.1,
// §5.3.1), read from a record the way the dissertation read its own: pure
// functions of the recorded arrays, so that a constructed record can check
// each definition (tests/sim/transition_metrics_test.cc).
#pragma once

#include <vector>

namespace tribo::scorecard {

// One transition as the instrument records it, tick by tick from the motion
// onset (tick k is the reading after k + 1 ticks of commanded motion).
struct TransitionRecord {
  double dt_s = 1e-4;
  double velocity_m_per_s = 0;  // commanded, > 0 (towards +x)
  // Friction each tick: the measured lateral force, tilt-corrected as §5.2
  // prescribes (measured + N tan(theta) when moving towards +x).
  std::vector<double> force_n;
  // The same, read over the 50 ms before the onset (its mean): the
  // pre-motion reading the rise is counted from.
  double force_before_n = 0;
  double force_noise_n = 0;            // per tick, of force_n
  std::vector<double> position_m;      // recorded lateral position
  double position_before_m = 0;        // its mean over the 50 ms before the onset
  std::vector<double> setpoint_m;      // commanded lateral position
  std::vector<double> tip_position_m;  // the tip's true position (may be empty)
  double tip_position_before_m = 0;
};

// What a record shows of one transition.
struct Breakaway {
  // Fs as the dissertation tabulates it (the goal rows): the rise of the
  // friction from the pre-motion reading to the stiction peak (eq. 27:
  // the controller's force builds from the onset, F = mki v t^2 / 2).
  double rise_n = 0;
  // Fs as the absolute tilt-corrected peak (the stiction peak, or the end of
  // the rise if there is no peak).
  double peak_n = 0;
  bool spike = false;          // the force fell >= 2 % below the peak afterwards
  double time_to_peak_s = 0;   // ts, from motion onset
  double stretch_m = 0;        // ds: measured position change from onset to the peak
  double lag_m = 0;            // dl: setpoint - measured position in steady sliding
  double steady_n = 0;         // mean friction over the last 30 % of the motion
  // §5.3.1, Fig. 5.11-5.12 as the dissertation's record shows them
  // (RecordedMotion): the largest recorded velocity over the commanded one,
  // and the largest recorded acceleration, raw and through Fig. 5.12's
  // 4-point moving average.
  double overshoot = 0;
  double peak_acceleration_m_per_s2 = 0;
  double peak_acceleration_ma4_m_per_s2 = 0;
  // The same from the tip's true position through the same record (no
  // readout noise): what the tip did, as that record would show it.
  double tip_overshoot = 0;
  double tip_peak_acceleration_m_per_s2 = 0;
  // Noise of the recorded velocity over the last half of the motion: a 1 kHz
  // record (1 ms means of the ticks) differenced centrally, RMS about its
  // 21 ms moving average.
  double velocity_noise_m_per_s = 0;
};

Breakaway measure_transition(const TransitionRecord& record);

// The dissertation's record of a break-away experiment: about 5000 points
// from the beginning to the end of the experiment (§4.3), over a load
// function of 16 s (5 s to the start, 3 s of loading, 3 s of unloading, 5 s
// back: §3.3.1's five segments, the motion onset at 8 s as in Figs.
// 5.11-5.13) plus a 16 µm scratch (Figs. 5.12-5.13 start at -8 µm; Table
// 3.2's usable scratch). The interval between its points at a commanded
// velocity: 3.29 ms at 36.4 µm/s, 3.38 ms at 18, 4.0 ms at 4, 19.2 ms at 0.2.
double dissertation_record_interval_s(double velocity_m_per_s);

// Velocity and acceleration as §5.3.1 computed them: "by successive division
// of the instantaneous displacement values with the difference in time", on
// a record whose every point is the mean of the ticks within its interval.
struct RecordedMotion {
  double peak_velocity_m_per_s = 0;
  double peak_acceleration_m_per_s2 = 0;
  double peak_acceleration_ma4_m_per_s2 = 0;  // Fig. 5.12's "4 per. Mov. Avg."
};

// position_m: ticks from the onset, dt_s apart; position_before_m: the
// position at rest before the onset (the record's point before it).
RecordedMotion motion_as_recorded(const std::vector<double>& position_m, double position_before_m, double dt_s,
                                  double interval_s);

}  // namespace tribo::scorecard
