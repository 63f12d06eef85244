// The safe stop sequence after a safety trip or an abort. Once begun, it
// replaces the load function's setpoints:
//
//   1. unload   the normal axis goes to open-loop force and its drive ramps
//               from the present drive to 0 at unload_rate_n_per_s; the
//               lateral axis holds its position (displacement mode,
//               bumpless): the present position setpoint, or in force
//               control the measured position, so an unloading tip is not
//               dragged;
//   2. hold     both held for hold_s once the normal drive is 0;
//   3. retract  the lateral setpoint moves to the neutral point x = 0 at
//               retract_speed_m_per_s;
//   4. settle   until the tip is within settle_tolerance_m of x = 0 (the
//               displacement loop lags a ramp), at least two recorded
//               samples and at most max_settle_s; then done().
//
// Without a finite position to hold (the reading failed, is not finite, or
// the trip says the position reading itself is suspect), the
// lateral axis cannot be held by position: it holds its last drive and
// retracts by ramping the drive to 0 (the spring returns the tip), at the
// spring force rate k * retract_speed.
#pragma once

#include <cstdint>

#include "daemon/load_function.h"
#include "hal/transducer.h"

namespace tribo::daemon {

struct StopSequenceParams {
  double period_s = 1e-4;
  double unload_rate_n_per_s = 10e-3;
  double hold_s = 0.05;
  double retract_speed_m_per_s = 10e-6;
  double lateral_spring_n_per_m = 116;
  double settle_tolerance_m = 0.1e-6;
  double max_settle_s = 2.0;
};

enum class StopPhase : std::uint8_t { kIdle, kUnload, kHold, kRetract, kSettle, kDone };

class StopSequence {
 public:
  explicit StopSequence(const StopSequenceParams& params) : p_(params) {}

  // Starts from the present drive, holding the lateral axis at hold_position_m
  // (not finite: by its drive); ticks_per_sample sets the settle time.
  void begin(const hal::DriveCommand& drive, double hold_position_m, std::uint32_t segment,
             std::uint32_t ticks_per_sample);

  // The setpoints of the next tick; frame is the present reading.
  TickSetpoints next(const hal::SensorFrame& frame);

  StopPhase phase() const { return phase_; }
  bool active() const { return phase_ != StopPhase::kIdle; }
  bool done() const { return phase_ == StopPhase::kDone; }

 private:
  StopSequenceParams p_;
  StopPhase phase_ = StopPhase::kIdle;
  TickSetpoints sp_;
  double normal_drive_n_ = 0;
  double lateral_ = 0;  // position (m) or, open loop, drive (N)
  bool lateral_open_loop_ = false;
  std::uint64_t phase_ticks_ = 0;
  std::uint64_t settle_ticks_ = 0;
};

}  // namespace tribo::daemon
