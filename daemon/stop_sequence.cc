#include "daemon/stop_sequence.h"

#include <algorithm>
#include <cmath>

namespace tribo::daemon {

namespace {

// Moves value towards 0 by at most step.
double towards_zero(double value, double step) {
  return value > 0 ? std::max(0.0, value - step) : std::min(0.0, value + step);
}

}  // namespace

void StopSequence::begin(const hal::DriveCommand& drive, double hold_position_m,
                         std::uint32_t segment, std::uint32_t ticks_per_sample) {
  phase_ = StopPhase::kUnload;
  phase_ticks_ = 0;
  settle_ticks_ = 2ull * std::max<std::uint32_t>(1, ticks_per_sample);
  normal_drive_n_ = std::isfinite(drive.normal_force_n) ? drive.normal_force_n : 0.0;
  lateral_open_loop_ = !std::isfinite(hold_position_m);
  lateral_ = lateral_open_loop_ ? drive.lateral_force_n : hold_position_m;
  sp_ = TickSetpoints{};
  sp_.segment = segment;
  sp_.ticks_per_sample = ticks_per_sample;
  sp_.normal_mode = NormalMode::kOpenLoopForce;
  sp_.lateral_mode = lateral_open_loop_ ? LateralMode::kOpenLoopDrive : LateralMode::kDisplacement;
}

TickSetpoints StopSequence::next(const hal::SensorFrame& frame) {
  ++phase_ticks_;
  sp_.segment_start = false;
  sp_.lateral_rate = 0;
  switch (phase_) {
    case StopPhase::kUnload:
      normal_drive_n_ = towards_zero(normal_drive_n_, p_.unload_rate_n_per_s * p_.period_s);
      if (normal_drive_n_ == 0) {
        phase_ = StopPhase::kHold;
        phase_ticks_ = 0;
      }
      break;
    case StopPhase::kHold:
      if (static_cast<double>(phase_ticks_) * p_.period_s >= p_.hold_s) {
        phase_ = StopPhase::kRetract;
        phase_ticks_ = 0;
      }
      break;
    case StopPhase::kRetract: {
      const double rate = lateral_open_loop_ ? p_.lateral_spring_n_per_m * p_.retract_speed_m_per_s
                                             : p_.retract_speed_m_per_s;
      const double before = lateral_;
      lateral_ = towards_zero(lateral_, rate * p_.period_s);
      if (!lateral_open_loop_) sp_.lateral_rate = (lateral_ - before) / p_.period_s;
      if (lateral_ == 0) {
        phase_ = StopPhase::kSettle;
        phase_ticks_ = 0;
      }
      break;
    }
    case StopPhase::kSettle: {
      const bool arrived = lateral_open_loop_ || std::fabs(frame.lateral_position_m) <= p_.settle_tolerance_m;
      const bool timed_out = static_cast<double>(phase_ticks_) * p_.period_s >= p_.max_settle_s;
      if ((arrived && phase_ticks_ >= settle_ticks_) || timed_out) phase_ = StopPhase::kDone;
      break;
    }
    case StopPhase::kIdle:
    case StopPhase::kDone:
      break;
  }
  sp_.normal = normal_drive_n_;
  sp_.lateral = lateral_;
  return sp_;
}

}  // namespace tribo::daemon
