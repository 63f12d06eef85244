#include "daemon/safety_supervisor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>

namespace tribo::daemon {

std::string_view trip_reason_text(TripReason reason) {
  switch (reason) {
    case TripReason::kNone: return "none";
    case TripReason::kEmergencyStop: return "emergency stop";
    case TripReason::kBackendLost: return "backend communication lost";
    case TripReason::kSensorStale: return "sensor data stale";
    case TripReason::kSensorNotFinite: return "sensor reading is not finite";
    case TripReason::kSensorOutOfRange: return "sensor reading out of range";
    case TripReason::kSensorFrozen: return "sensor reading frozen";
    case TripReason::kLoopOverrun: return "loop overrun";
    case TripReason::kNormalForce: return "normal force beyond the limit";
    case TripReason::kLateralForce: return "lateral force beyond the limit";
    case TripReason::kLateralTravel: return "lateral position beyond the travel limit";
    case TripReason::kNormalTravel: return "normal displacement beyond the travel limit";
    case TripReason::kLateralSpeed: return "lateral speed beyond the limit";
    case TripReason::kLateralAcceleration: return "lateral acceleration beyond the limit";
    case TripReason::kTrackingError: return "lateral tracking error beyond the limit";
    case TripReason::kBreakpoint: return "loaded tip at the breakpoint";
    case TripReason::kSnapDownNormal: return "normal axis snap-down margin";
    case TripReason::kSnapDownLateral: return "lateral axis snap-down margin";
    case TripReason::kCommandInvalid: return "command refused before the backend";
    case TripReason::kRecordingFailed: return "recording failed";
    case TripReason::kFrictionCompensation: return "friction compensation refused";
  }
  return "unknown";
}

SupervisorParams supervisor_params_from_config(const v1::DaemonConfig& c) {
  const auto& l = c.limits();
  const auto& s = c.supervisor();
  SupervisorParams p;
  p.period_s = 1.0 / c.controller().loop_rate_hz();
  p.max_normal_force_n = l.max_normal_force_n();
  p.max_lateral_force_n = l.max_lateral_force_n();
  p.max_lateral_travel_m = l.max_lateral_travel_m();
  p.max_normal_travel_m = l.max_normal_travel_m();
  p.force_filter_hz = s.force_filter_hz();
  p.motion_filter_hz = s.motion_filter_hz();
  p.max_lateral_speed_m_per_s = s.max_lateral_speed_m_per_s();
  p.max_lateral_acceleration_m_per_s2 = s.max_lateral_acceleration_m_per_s2();
  p.frozen_sensor_ticks = s.frozen_sensor_ticks();
  p.frozen_channel_ticks = s.frozen_channel_ticks();
  p.stale_sensor_ticks = std::max<std::uint32_t>(1, s.stale_sensor_ticks());
  p.lateral_position_range_m = s.lateral_position_range_m();
  p.lateral_force_range_n = s.lateral_force_range_n();
  p.normal_force_range_n = s.normal_force_range_n();
  p.normal_displacement_range_m = s.normal_displacement_range_m();
  p.min_stiffness_ratio = s.min_stiffness_ratio();
  p.contact_force_n = s.contact_force_n();
  p.breakpoint_guard_m = l.breakpoint_guard_m();
  p.overrun_trip_count = s.overrun_trip_count();
  p.overrun_window_s = s.overrun_window_s();
  p.tracking_error_m = s.tracking_error_m();
  p.tracking_lag_s = s.tracking_lag_s();
  p.normal_axis = electrostatic_axis_from_config(c.transducer().normal());
  p.lateral_axis = electrostatic_axis_from_config(c.transducer().lateral());
  // The most the amplifier can push, anywhere within the travel: max_drive_v
  // on the active plate at its narrowest gap. A command beyond it is a bug,
  // never a demand (without transducer constants only finiteness is checked).
  const auto ceiling = [](const ElectrostaticAxis& a, double travel_m) {
    const double gap = std::min(a.gap_positive_m, a.gap_negative_m) - travel_m;
    const double f = 0.5 * a.permittivity_f_per_m * a.plate_area_m2 * a.max_drive_v * a.max_drive_v / (gap * gap);
    return gap > 0 && f > 0 && std::isfinite(f) ? f : std::numeric_limits<double>::infinity();
  };
  const double normal_max = ceiling(p.normal_axis, l.max_normal_travel_m());
  const double lateral_max = ceiling(p.lateral_axis, l.max_lateral_travel_m());
  p.normal_drive_min_n = -normal_max;
  p.normal_drive_max_n = normal_max;
  p.lateral_drive_min_n = -lateral_max;
  p.lateral_drive_max_n = lateral_max;
  p.max_friction_compensation_n =
      s.max_friction_compensation_n() > 0 ? s.max_friction_compensation_n() : l.max_lateral_force_n();
  return p;
}

SafetySupervisor::SafetySupervisor(const SupervisorParams& params) : p_(params) {
  normal_force_.configure(p_.force_filter_hz, p_.period_s);
  lateral_force_.configure(p_.force_filter_hz, p_.period_s);
  velocity_.configure(p_.motion_filter_hz, p_.period_s);
  acceleration_.configure(p_.motion_filter_hz, p_.period_s);
  p_.overrun_trip_count = std::min<std::uint32_t>(p_.overrun_trip_count, kMaxOverrunRing);
  overrun_window_ticks_ = static_cast<std::uint64_t>(std::llround(p_.overrun_window_s / p_.period_s));
  rate_decay_ = p_.tracking_lag_s > 0 ? std::exp(-p_.period_s / p_.tracking_lag_s) : 0.0;
}

TripReason SafetySupervisor::latch(TripReason reason, std::uint64_t tick, const char* format,
                                   double a, double b) {
  trip_.reason = reason;
  trip_.tick = tick;
  // format takes at most two doubles; constant texts ignore them. The tick
  // path allocates nothing, so the detail goes into the trip's fixed buffer
  // (snprintf truncates, never overflows).
  std::snprintf(trip_.detail.data(), trip_.detail.size(), format, a, b);
  return reason;
}

TripReason SafetySupervisor::latch_snap_down(TripReason reason, std::uint64_t tick,
                                             const DriveAssessment& a, double force_n, double position_m) {
  trip_.reason = reason;
  trip_.tick = tick;
  std::snprintf(trip_.detail.data(), trip_.detail.size(),
                "k_eff/k = %.3g below %.3g: a drive of %.3g N at %.3g m needs %.0f V, pull-in there at %.0f V%s",
                a.stiffness_ratio, p_.min_stiffness_ratio, force_n, position_m, a.active_voltage_v,
                a.pull_in_voltage_v, a.gap_closed ? " (gap closed)" : "");
  return reason;
}

bool SafetySupervisor::drive_in_range(const hal::DriveCommand& d) const {
  return std::isfinite(d.normal_force_n) && std::isfinite(d.lateral_force_n) &&
         d.normal_force_n >= p_.normal_drive_min_n && d.normal_force_n <= p_.normal_drive_max_n &&
         d.lateral_force_n >= p_.lateral_drive_min_n && d.lateral_force_n <= p_.lateral_drive_max_n;
}

bool SafetySupervisor::command_allowed(const hal::DriveCommand& d, double normal_setpoint, double lateral_setpoint,
                                       bool setpoints_must_be_finite, std::uint64_t tick) {
  const bool drive_ok = drive_in_range(d);
  const bool setpoints_ok =
      !setpoints_must_be_finite || (std::isfinite(normal_setpoint) && std::isfinite(lateral_setpoint));
  if (drive_ok && setpoints_ok) return true;
  if (!tripped()) {
    if (!drive_ok) {
      latch(TripReason::kCommandInvalid, tick, "drive normal %.6g N, lateral %.6g N is not finite or out of range",
            d.normal_force_n, d.lateral_force_n);
    } else {
      latch(TripReason::kCommandInvalid, tick, "setpoint normal %.6g, lateral %.6g is not finite",
            normal_setpoint, lateral_setpoint);
    }
  }
  return drive_ok;  // a finite, in-range drive may still go out (the stop sequence's)
}

bool SafetySupervisor::compensation_allowed(double c, std::uint64_t tick) {
  if (std::isfinite(c) && std::fabs(c) <= p_.max_friction_compensation_n) return true;
  if (!tripped()) {
    latch(TripReason::kFrictionCompensation, tick, "compensation %.6g N is not finite or beyond +-%.6g N", c,
          p_.max_friction_compensation_n);
  }
  return false;
}

bool SafetySupervisor::overrun_trip(std::uint64_t overruns, std::uint64_t tick) {
  if (!overruns_primed_) {
    last_overruns_ = overruns;
    overruns_primed_ = true;
  }
  const std::uint64_t fresh = overruns - last_overruns_;
  last_overruns_ = overruns;
  if (p_.overrun_trip_count == 0) return false;
  for (std::uint64_t i = 0; i < fresh; ++i) overrun_ticks_[overrun_count_++ % kMaxOverrunRing] = tick;
  const std::size_t k = p_.overrun_trip_count;
  if (overrun_count_ < k) return false;
  // The k-th most recent overrun, against the window.
  const std::uint64_t oldest = overrun_ticks_[(overrun_count_ - k) % kMaxOverrunRing];
  return tick - oldest < overrun_window_ticks_;
}

TripReason SafetySupervisor::check(const SupervisorInput& in, std::uint64_t tick) {
  if (tripped()) return TripReason::kNone;
  return evaluate(in, tick);
}

TripReason SafetySupervisor::evaluate(const SupervisorInput& in, std::uint64_t tick) {
  const hal::SensorFrame& f = in.frame;
  if (in.emergency_stop) return latch(TripReason::kEmergencyStop, tick, "requested by a client", 0, 0);
  if (in.recording_failed) {
    return latch(TripReason::kRecordingFailed, tick, "a write to the data directory failed; the run stops", 0, 0);
  }
  if (in.read == hal::IoResult::kLinkDown || in.last_write == hal::IoResult::kLinkDown) {
    return latch(TripReason::kBackendLost, tick, "the backend reported its link down", 0, 0);
  }
  const bool fresh = in.read == hal::IoResult::kOk;
  failed_reads_ = fresh ? 0 : failed_reads_ + 1;
  if (failed_reads_ >= p_.stale_sensor_ticks) {
    return latch(TripReason::kSensorStale, tick, "%.0f consecutive reads failed (limit %.0f)",
                 failed_reads_, p_.stale_sensor_ticks);
  }
  if (overrun_trip(in.overruns, tick)) {
    return latch(TripReason::kLoopOverrun, tick, "%.0f overruns within %g s", p_.overrun_trip_count,
                 p_.overrun_window_s);
  }
  // A failed read carries no values (NaN, hal/transducer.h): nothing more to check this tick.
  if (!fresh) return TripReason::kNone;
  const double channels[4] = {f.lateral_position_m, f.lateral_force_n, f.normal_force_n,
                              f.normal_displacement_m};
  static constexpr const char* kNames[4] = {"lateral position", "lateral force", "normal force",
                                            "normal displacement"};
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(channels[i])) {
      trip_.reason = TripReason::kSensorNotFinite;
      trip_.tick = tick;
      trip_.lateral_position_suspect = i == 0;
      std::snprintf(trip_.detail.data(), trip_.detail.size(), "%s reads %f", kNames[i], channels[i]);
      return trip_.reason;
    }
  }
  const double ranges[4] = {p_.lateral_position_range_m, p_.lateral_force_range_n,
                            p_.normal_force_range_n, p_.normal_displacement_range_m};
  for (int i = 0; i < 4; ++i) {
    if (ranges[i] > 0 && std::fabs(channels[i]) > ranges[i]) {
      trip_.reason = TripReason::kSensorOutOfRange;
      trip_.tick = tick;
      trip_.lateral_position_suspect = i == 0;
      std::snprintf(trip_.detail.data(), trip_.detail.size(), "%s reads %g, full scale +-%g (SI)",
                    kNames[i], channels[i], ranges[i]);
      return trip_.reason;
    }
  }
  std::uint32_t least_repeats = ~0u;
  for (int i = 0; i < 4; ++i) {
    const std::uint32_t repeats = repeats_[i].update(channels[i]);
    least_repeats = std::min(least_repeats, repeats);
    if (p_.frozen_channel_ticks > 0 && repeats >= p_.frozen_channel_ticks) {
      trip_.reason = TripReason::kSensorFrozen;
      trip_.tick = tick;
      trip_.lateral_position_suspect = i == 0;
      std::snprintf(trip_.detail.data(), trip_.detail.size(), "%s repeated %g for %u ticks", kNames[i],
                    channels[i], p_.frozen_channel_ticks);
      return trip_.reason;
    }
  }
  if (p_.frozen_sensor_ticks > 0 && least_repeats >= p_.frozen_sensor_ticks) {
    trip_.lateral_position_suspect = true;
    return latch(TripReason::kSensorFrozen, tick, "all four channels repeated their values for %.0f ticks",
                 p_.frozen_sensor_ticks, 0);
  }
  // A position reading that stands still while its setpoint moves on is a
  // saturated or stuck readout (an ADC at its rail reads one code whatever
  // the tip does), even where a coarse ADC may repeat a still tip's value.
  const std::uint32_t position_repeats = repeats_[0].count();
  if (position_repeats == 0 || !in.lateral_displacement_mode) position_setpoint_anchor_m_ = in.lateral_setpoint_m;
  if (p_.frozen_sensor_ticks > 0 && in.lateral_displacement_mode && position_repeats >= p_.frozen_sensor_ticks &&
      std::fabs(in.lateral_setpoint_m - position_setpoint_anchor_m_) > kFrozenPositionTravelM) {
    trip_.lateral_position_suspect = true;
    return latch(TripReason::kSensorFrozen, tick,
                 "lateral position stuck at %g m while its setpoint moved %g m (saturated or frozen readout)",
                 f.lateral_position_m, in.lateral_setpoint_m - position_setpoint_anchor_m_);
  }
  // Filtered forces, velocity and acceleration.
  const double normal = normal_force_.update(f.normal_force_n);
  const double lateral = lateral_force_.update(f.lateral_force_n);
  const double x = f.lateral_position_m;
  if (motion_samples_ > 0) {
    const double v = velocity_.update((x - previous_position_m_) / p_.period_s);
    if (motion_samples_ > 1) acceleration_.update((v - previous_velocity_) / p_.period_s);
    previous_velocity_ = v;
  }
  previous_position_m_ = x;
  ++motion_samples_;

  if (normal > p_.max_normal_force_n) {
    return latch(TripReason::kNormalForce, tick, "filtered normal force %g N above %g N", normal,
                 p_.max_normal_force_n);
  }
  if (std::fabs(lateral) > p_.max_lateral_force_n) {
    return latch(TripReason::kLateralForce, tick, "filtered lateral force %g N beyond +-%g N", lateral,
                 p_.max_lateral_force_n);
  }
  if (std::fabs(x) > p_.max_lateral_travel_m) {
    return latch(TripReason::kLateralTravel, tick, "lateral position %g m beyond +-%g m", x,
                 p_.max_lateral_travel_m);
  }
  if (p_.max_normal_travel_m > 0 && std::fabs(f.normal_displacement_m) > p_.max_normal_travel_m) {
    return latch(TripReason::kNormalTravel, tick, "normal displacement %g m beyond +-%g m",
                 f.normal_displacement_m, p_.max_normal_travel_m);
  }
  if (p_.max_lateral_speed_m_per_s > 0 && std::fabs(velocity_.value()) > p_.max_lateral_speed_m_per_s) {
    return latch(TripReason::kLateralSpeed, tick, "lateral speed %g m/s beyond %g m/s", velocity_.value(),
                 p_.max_lateral_speed_m_per_s);
  }
  if (p_.max_lateral_acceleration_m_per_s2 > 0 &&
      std::fabs(acceleration_.value()) > p_.max_lateral_acceleration_m_per_s2) {
    return latch(TripReason::kLateralAcceleration, tick, "lateral acceleration %g m/s2 beyond %g m/s2",
                 acceleration_.value(), p_.max_lateral_acceleration_m_per_s2);
  }
  // The loop lags a ramp for a while after it ends: the rate that sets the
  // bound is a peak of the setpoint rate decaying with the lag time.
  rate_envelope_ = std::max(std::fabs(in.lateral_setpoint_rate_m_per_s), rate_envelope_ * rate_decay_);
  if (in.lateral_displacement_mode && p_.tracking_error_m > 0) {
    const double error = std::fabs(in.lateral_setpoint_m - x);
    const double bound = p_.tracking_error_m + p_.tracking_lag_s * rate_envelope_;
    if (error > bound) {
      return latch(TripReason::kTrackingError, tick, "position %g m behind its setpoint (bound %g m)",
                   error, bound);
    }
  }
  const bool loaded = normal > p_.contact_force_n;
  if (loaded && std::fabs(x) < p_.breakpoint_guard_m) {
    return latch(TripReason::kBreakpoint, tick, "loaded tip at x = %g m, within %g m of the breakpoint", x,
                 p_.breakpoint_guard_m);
  }
  if (p_.min_stiffness_ratio > 0) {
    const double z = f.normal_displacement_m;
    const double contact = loaded && z > 0 ? normal / z : 0.0;
    // Most ticks are far from the limit: a division-free certificate clears
    // them; otherwise the exact ratio decides, and the full assessment
    // (voltages for the message) is made only when it trips.
    if (!stiffness_certainly_above(p_.normal_axis, in.drive.normal_force_n, z, contact, p_.min_stiffness_ratio)) {
      const DriveStiffness n = drive_stiffness(p_.normal_axis, in.drive.normal_force_n, z, contact);
      if (n.gap_closed || n.stiffness_ratio < p_.min_stiffness_ratio) {
        return latch_snap_down(TripReason::kSnapDownNormal, tick,
                               assess_drive(p_.normal_axis, in.drive.normal_force_n, z, contact),
                               in.drive.normal_force_n, z);
      }
    }
    if (!stiffness_certainly_above(p_.lateral_axis, in.drive.lateral_force_n, x, 0.0, p_.min_stiffness_ratio)) {
      const DriveStiffness l = drive_stiffness(p_.lateral_axis, in.drive.lateral_force_n, x, 0.0);
      if (l.gap_closed || l.stiffness_ratio < p_.min_stiffness_ratio) {
        return latch_snap_down(TripReason::kSnapDownLateral, tick,
                               assess_drive(p_.lateral_axis, in.drive.lateral_force_n, x, 0.0),
                               in.drive.lateral_force_n, x);
      }
    }
  }
  return TripReason::kNone;
}

}  // namespace tribo::daemon
