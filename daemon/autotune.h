// Relay autotune (Astrom-Hagglund 1984) of the lateral displacement loop.
//
// With the normal axis unloaded, the lateral axis is brought to position_m
// with the present PID and held there; the drive that holds it is the bias
// u0. Then a relay replaces the PID:
//
//   u = u0 + d   if e >  eps        e = position_m - y
//   u = u0 - d   if e < -eps        (else u keeps its last value)
//
// which drives the loop into a limit cycle at the frequency where the plant
// (with the relay's hysteresis lag) turns -180 degrees. A lightly damped
// plant (the unloaded lateral axis has Q ~ 40) needs tens of cycles to settle
// onto it, so the measurement waits until the last `cycles` periods and
// amplitudes agree within 2 % and their means within 0.5 % of the `cycles`
// before; Pu is their mean period (between switches to +d), a their mean
// half peak-to-peak of y. The describing
// function of a relay with hysteresis gives the ultimate gain
//
//   Ku = 4 d / (pi sqrt(a^2 - eps^2))
//
// and the proposal is Ziegler-Nichols' PID rule: kp = 0.6 Ku, Ti = Pu / 2,
// Td = Pu / 8 (ki = kp / Ti, kd = kp Td), keeping the present loop's
// structure (set-point weights, derivative filter, limits, anti-windup).
// Afterwards the axis returns to where it started with the present PID.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "daemon/pid.h"
#include "daemon/sample_queue.h"
#include "proto/sample_record.h"
#include "hal/transducer.h"

namespace tribo::daemon {

struct AutotuneParams {
  double relay_amplitude_n = 100e-6;  // d
  double hysteresis_m = 5e-9;         // eps, a few times the position noise
  double position_m = 2e-6;
  std::uint32_t cycles = 10;
  double max_duration_s = 5;
  double move_speed_m_per_s = 10e-6;  // to and from position_m
  double max_travel_m = 15e-6;        // aborts beyond this
  PidGains present;                   // the loop's gains now
  // Checked every tick (the experiment runs as an activity of the supervised
  // loop): when it reads true the experiment stops at once, the lateral
  // drive goes to zero (the axis is unloaded: its spring takes it home) and
  // the result says "emergency stop". May be null.
  const std::atomic<bool>* stop_requested = nullptr;
  // Set to the monotonic time of the tick that acted on stop_requested.
  std::atomic<std::int64_t>* stop_acted_ns = nullptr;
  // The drive range a command must lie in (the supervisor's last check):
  // a non-finite or larger drive is refused and ends the experiment.
  double max_lateral_drive_n = 1e300;
  // The experiment is recorded like a run (daemon/activity_recording.h):
  // each tick goes through the acquisition filter, ticks_per_sample ticks a
  // sample, into this queue (a full queue drops and counts). Null: not
  // recorded. Segments: 0 move to position_m, 1 relay, 2 return.
  SpscQueue<Sample>* samples = nullptr;
  std::atomic<std::uint64_t>* samples_dropped = nullptr;
  std::uint32_t ticks_per_sample = 10;
};

// The recorded segments' names, by segment index.
inline constexpr const char* kAutotuneSegmentNames[] = {"move to the relay position", "relay", "return"};

struct AutotuneResult {
  bool ok = false;
  std::string error;
  double ultimate_gain_n_per_m = 0;
  double ultimate_period_s = 0;
  double amplitude_m = 0;
  std::uint32_t cycles = 0;           // measured
  std::uint32_t settling_cycles = 0;  // before the limit cycle was steady
  PidGains proposed;
  std::string rule;
  std::uint64_t ticks = 0;
  bool emergency_stopped = false;  // stop_requested ended it
  bool command_refused = false;    // a non-finite or out-of-range drive ended it
};

AutotuneResult relay_autotune(hal::Transducer& transducer, const AutotuneParams& params);

}  // namespace tribo::daemon
