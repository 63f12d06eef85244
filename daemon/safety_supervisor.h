// The safety supervisor: checks every tick, before the drive reaches the HAL,
// and latches the first trip. The run loop then stops the segment runner and
// runs the safe stop sequence (daemon/stop_sequence.h); only an explicit
// re-arm clears the fault (daemon/instrument_service.h).
//
// Checks, in this order (the first that fails is the recorded reason):
//   emergency stop      a client asked for it
//   backend lost        read() or write() reported kLinkDown
//   sensor stale        stale_sensor_ticks consecutive failed reads (kTimeout);
//                       a failed read carries NaN (hal/transducer.h), so the
//                       checks of values below skip that tick
//   sensor not finite   NaN or infinity on any channel
//   sensor out of range beyond a channel's full scale (supervisor.*_range_*)
//   sensor frozen       all four channels bit-identical for frozen_sensor_ticks
//                       ticks (the readout stopped), or one channel for
//                       frozen_channel_ticks (only where noise exceeds the
//                       resolution of every channel; 0 turns either off)
//   loop overrun        overrun_trip_count overruns within overrun_window_s
//                       (checked right after the stale count)
//   normal force        filtered contact force above limits.max_normal_force_n
//   lateral force       |filtered lateral force| above limits.max_lateral_force_n
//   lateral travel      |position| beyond limits.max_lateral_travel_m
//   normal travel       |normal displacement| beyond limits.max_normal_travel_m
//   lateral speed       |filtered velocity| above max_lateral_speed_m_per_s
//   lateral accel.      |filtered acceleration| above max_lateral_acceleration
//   tracking error      displacement mode: |setpoint - position| above
//                       tracking_error_m + tracking_lag_s |setpoint rate|,
//                       the rate a peak that decays with tracking_lag_s (the
//                       loop still lags after a ramp ends); a stuck actuator
//                       leaves the tip behind
//   friction compensation (with the command, before it is written) the
//                       compensation's share not finite or beyond
//                       max_friction_compensation_n
//   breakpoint          loaded (filtered contact force above contact_force_n)
//                       within breakpoint_guard_m of x = 0 (§3.2.5)
//   snap-down           k_eff / k below min_stiffness_ratio for the applied
//                       drive at the measured position (daemon/electrostatic_drive.h);
//                       the normal axis counts the contact's secant stiffness
//                       N / displacement as support while loaded
//
// Noise: the force channels carry white noise (lateral 10 µN RMS per tick,
// Table 3.2), so force limits act on a first-order low-pass at
// force_filter_hz (200 Hz: noise bandwidth pi/2 * 200 Hz against the 5 kHz
// Nyquist band leaves 0.25 of the RMS, 2.5 µN; a 1 % excursion above a 2 mN
// limit is then 8 standard deviations, while a real overload is seen within
// about 1 ms). Velocity and acceleration come from differences of the
// position, low-passed at motion_filter_hz. Trips latch, so no hysteresis is
// needed for them; a value hovering at a limit trips once and stays tripped.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "daemon/electrostatic_drive.h"
#include "daemon/signal_filters.h"
#include "hal/transducer.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

enum class TripReason : std::uint8_t {
  kNone,
  kEmergencyStop,
  kBackendLost,
  kSensorStale,
  kSensorNotFinite,
  kSensorOutOfRange,
  kSensorFrozen,
  kLoopOverrun,
  kNormalForce,
  kLateralForce,
  kLateralTravel,
  kNormalTravel,
  kLateralSpeed,
  kLateralAcceleration,
  kTrackingError,
  kBreakpoint,
  kSnapDownNormal,
  kSnapDownLateral,
  kCommandInvalid,    // the last check before a write: a non-finite or out-of-range command
  kRecordingFailed,   // the recorder could not write: samples would be lost unseen
  kFrictionCompensation,  // the compensation's share not finite or beyond its limit
};

std::string_view trip_reason_text(TripReason reason);

// Everything the supervisor checks against, SI.
struct SupervisorParams {
  double period_s = 1e-4;
  double max_normal_force_n = 0;
  double max_lateral_force_n = 0;
  double max_lateral_travel_m = 0;
  double max_normal_travel_m = 0;
  double force_filter_hz = 0;
  double motion_filter_hz = 0;
  double max_lateral_speed_m_per_s = 0;
  double max_lateral_acceleration_m_per_s2 = 0;
  std::uint32_t frozen_sensor_ticks = 0;
  std::uint32_t frozen_channel_ticks = 0;
  std::uint32_t stale_sensor_ticks = 1;
  double lateral_position_range_m = 0;
  double lateral_force_range_n = 0;
  double normal_force_range_n = 0;
  double normal_displacement_range_m = 0;
  double min_stiffness_ratio = 0;
  double contact_force_n = 0;
  double breakpoint_guard_m = 0;
  std::uint32_t overrun_trip_count = 0;
  double overrun_window_s = 0;
  double tracking_error_m = 0;
  double tracking_lag_s = 0;
  ElectrostaticAxis normal_axis;
  ElectrostaticAxis lateral_axis;
  // The drive a backend may be sent, per axis: [min, max] N. Beyond it (or
  // not finite) the command is refused whatever the validator said.
  double normal_drive_min_n = 0, normal_drive_max_n = 0;
  double lateral_drive_min_n = 0, lateral_drive_max_n = 0;
  // The most the friction compensation may add to the lateral drive, N.
  double max_friction_compensation_n = 0;
};

SupervisorParams supervisor_params_from_config(const v1::DaemonConfig& config);

// What the supervisor sees of one tick.
struct SupervisorInput {
  hal::SensorFrame frame;         // the latest reading (NaN after a failed read)
  hal::IoResult read = hal::IoResult::kOk;
  hal::IoResult last_write = hal::IoResult::kOk;
  std::uint64_t overruns = 0;     // the backend's running count
  hal::DriveCommand drive;        // the drive applied now (last tick's command)
  bool emergency_stop = false;
  bool recording_failed = false;  // the recorder reported a failed write
  bool lateral_displacement_mode = true;
  double lateral_setpoint_m = 0;
  double lateral_setpoint_rate_m_per_s = 0;
};

// A latched trip, with a human-readable detail (values and limit), formatted
// into a fixed buffer when it happens: no allocation on the tick path.
struct Trip {
  TripReason reason = TripReason::kNone;
  std::uint64_t tick = 0;
  // The lateral position reading itself failed (frozen, not finite, out of
  // range): the stop sequence must not hold the tip by it.
  bool lateral_position_suspect = false;
  std::array<char, 192> detail{};
};

class SafetySupervisor {
 public:
  explicit SafetySupervisor(const SupervisorParams& params);

  // Returns the reason of a new trip, or kNone. After a trip it keeps
  // returning kNone; trip() stays latched.
  TripReason check(const SupervisorInput& in, std::uint64_t tick);

  // The last check before a command reaches the backend (defence in depth:
  // whatever the validator and the controller did). A non-finite or
  // out-of-range drive, or a non-finite setpoint while a protocol runs,
  // latches kCommandInvalid and returns false: the caller must not write it.
  // Before a trip the first refusal is latched; after one, it only answers.
  bool command_allowed(const hal::DriveCommand& drive, double normal_setpoint, double lateral_setpoint,
                       bool setpoints_must_be_finite, std::uint64_t tick);
  // The friction compensation's share of a command (daemon/controller.h),
  // checked before the command itself: not finite, or beyond
  // max_friction_compensation_n, latches kFrictionCompensation and returns
  // false (the command must not be written).
  bool compensation_allowed(double compensation_n, std::uint64_t tick);
  // Whether a drive is finite and within the drive range (no latch).
  bool drive_in_range(const hal::DriveCommand& drive) const;

  const Trip& trip() const { return trip_; }
  bool tripped() const { return trip_.reason != TripReason::kNone; }

  // The filtered values the checks use (for status and tests).
  double filtered_normal_force_n() const { return normal_force_.value(); }
  double filtered_lateral_force_n() const { return lateral_force_.value(); }
  double lateral_velocity_m_per_s() const { return velocity_.value(); }
  double lateral_acceleration_m_per_s2() const { return acceleration_.value(); }

 private:
  TripReason evaluate(const SupervisorInput& in, std::uint64_t tick);
  TripReason latch(TripReason reason, std::uint64_t tick, const char* format, double a, double b);
  TripReason latch_snap_down(TripReason reason, std::uint64_t tick, const DriveAssessment& a,
                             double force_n, double position_m);
  bool overrun_trip(std::uint64_t overruns, std::uint64_t tick);

  SupervisorParams p_;
  Trip trip_;
  LowPass normal_force_, lateral_force_, velocity_, acceleration_;
  std::array<RepeatCounter, 4> repeats_;
  std::uint32_t frame_repeats_ = 0;
  double previous_position_m_ = 0;
  double previous_velocity_ = 0;
  std::uint64_t motion_samples_ = 0;
  std::uint32_t failed_reads_ = 0;
  std::uint64_t last_overruns_ = 0;
  bool overruns_primed_ = false;
  static constexpr std::size_t kMaxOverrunRing = 64;
  std::array<std::uint64_t, kMaxOverrunRing> overrun_ticks_{};
  std::size_t overrun_count_ = 0;  // total recorded into the ring
  std::uint64_t overrun_window_ticks_ = 0;
  double position_setpoint_anchor_m_ = 0;  // the setpoint when the position last changed
  static constexpr double kFrozenPositionTravelM = 100e-9;  // far above any position LSB
  double rate_envelope_ = 0;  // peak |setpoint rate|, decaying with tracking_lag_s
  double rate_decay_ = 0;
};

}  // namespace tribo::daemon
