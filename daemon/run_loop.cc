#include "daemon/run_loop.h"

#include <sys/prctl.h>

#include <algorithm>
#include <cmath>
#include <thread>

#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

std::uint32_t sample_flags_of_sensor_status(std::uint32_t status_bits) {
  std::uint32_t flags = 0;
  if (status_bits & hal::kSubstepCapHit) flags |= v1::SUBSTEP_CAP_HIT;
  if (status_bits & hal::kLateralSnapDown) flags |= v1::LATERAL_SNAP_DOWN;
  if (status_bits & hal::kDriveHandover) flags |= v1::DRIVE_HANDOVER;
  return flags;
}

RunLoopConfig run_loop_config_from(const v1::DaemonConfig& config) {
  RunLoopConfig c;
  c.controller = controller_params_from_config(config);
  c.supervisor = supervisor_params_from_config(config);
  const auto& s = config.supervisor();
  c.stop.period_s = 1.0 / config.controller().loop_rate_hz();
  c.stop.unload_rate_n_per_s = s.unload_rate_n_per_s();
  c.stop.hold_s = s.hold_s();
  c.stop.retract_speed_m_per_s = s.retract_speed_m_per_s();
  c.stop.lateral_spring_n_per_m = config.transducer().lateral().spring_n_per_m();
  return c;
}

std::string trip_description(const Trip& trip) {
  std::string text(trip_reason_text(trip.reason));
  if (trip.detail[0] != '\0') text += std::string(": ") + trip.detail.data();
  return text;
}

RunLoop::RunLoop(hal::Transducer& transducer, const LoadFunction& load_function,
                 const RunLoopConfig& config, SpscQueue<Sample>& queue, RunControl& control,
                 RunTelemetry& telemetry)
    : transducer_(transducer),
      runner_(load_function),
      config_(config),
      queue_(queue),
      control_(control),
      telemetry_(telemetry),
      controller_(config.controller),
      supervisor_(config.supervisor),
      stop_(config.stop),
      period_s_(transducer.period_s()) {
  sp_.lateral_mode = LateralMode::kDisplacement;
}

void RunLoop::record(const Sample& tick_sample, std::uint32_t ticks_per_sample) {
  Sample recorded;
  if (!acquisition_.add(tick_sample, ticks_per_sample, recorded)) return;
  while (!queue_.try_push(recorded)) {
    if (!config_.backpressure) {
      telemetry_.samples_dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    std::this_thread::yield();
  }
  telemetry_.samples.fetch_add(1, std::memory_order_relaxed);
}

void RunLoop::start_stopping(RunEnd end) {
  if (end == RunEnd::kTripped) {
    outcome_.end = RunEnd::kTripped;
    outcome_.trip = supervisor_.trip();
    outcome_.trip_time_s = static_cast<double>(tick_) * period_s_;
    telemetry_.tripped.store(true, std::memory_order_relaxed);
  } else if (!stopping_) {
    outcome_.end = end;
  }
  if (stopping_) return;  // a trip while stopping after an abort: same sequence
  stopping_ = true;
  // Hold where the lateral loop holds now: its setpoint, the break-away hold,
  // or in force control the measured position (NaN: hold by the drive).
  double hold = frame_.lateral_position_m;
  if (sp_.lateral_mode == LateralMode::kDisplacement) hold = sp_.lateral;
  if (controller_.breakaway_hold()) hold = controller_.hold_position_m();
  if (tick_ == 0) hold = frame_.lateral_position_m;  // no setpoint yet
  if (end == RunEnd::kTripped && outcome_.trip.lateral_position_suspect) hold = std::nan("");
  // From the drive the backend holds now: the last one written.
  stop_.begin(written_, hold, sp_.segment, sp_.ticks_per_sample);
}

void RunLoop::finish() {
  finished_ = true;
  outcome_.cycles = tick_;
}

bool RunLoop::tick() {
  if (finished_) return false;
  if (!stopping_ && runner_.finished(tick_)) {
    finish();
    return false;
  }
  // After a stop: end once the sequence is done at a recorded sample boundary.
  if (stopping_ && stop_.done() && acquisition_.empty()) {
    finish();
    return false;
  }
  timed_ = config_.time_stages_every != 0 && tick_ % config_.time_stages_every == 0;
  const std::uint64_t t0 = now_ns();

  const hal::IoResult read = transducer_.read(frame_);
  // The last finite value of each position channel: where a segment begins
  // when its first tick's read fails.
  if (std::isfinite(frame_.lateral_position_m)) last_lateral_position_m_ = frame_.lateral_position_m;
  if (std::isfinite(frame_.normal_displacement_m)) last_normal_displacement_m_ = frame_.normal_displacement_m;
  const std::uint64_t t1 = now_ns();

  GainUpdate update;
  while (control_.gain_updates.try_pop(update)) controller_.set_gains(update.loop, update.gains);
  SupervisorInput in;
  in.frame = frame_;
  in.read = read;
  in.last_write = last_write_;
  in.overruns = transducer_.overruns();
  in.drive = controller_.last_drive();
  in.emergency_stop = control_.emergency_stop.load(std::memory_order_relaxed);
  in.recording_failed = control_.recording_failed.load(std::memory_order_relaxed);
  // Tracking needs a setpoint: none exists before the first tick's.
  in.lateral_displacement_mode =
      tick_ > 0 && sp_.lateral_mode == LateralMode::kDisplacement && !controller_.breakaway_hold();
  in.lateral_setpoint_m = sp_.lateral;
  in.lateral_setpoint_rate_m_per_s = sp_.lateral_rate;
  const TripReason trip = supervisor_.check(in, tick_);
  if (trip != TripReason::kNone) start_stopping(RunEnd::kTripped);
  if (!stopping_ && control_.abort_requested.load(std::memory_order_relaxed)) {
    start_stopping(RunEnd::kAborted);
  }
  telemetry_.overruns.store(in.overruns, std::memory_order_relaxed);
  const std::uint64_t t2 = now_ns();

  if (stopping_) {
    sp_ = stop_.next(frame_);
  } else {
    MeasuredStart measured;
    measured.normal_drive_n = controller_.last_drive().normal_force_n;
    // Forces from the supervisor's low-pass (the raw channels are noisy); a
    // contact force cannot be negative, so a closed loop never starts there.
    measured.normal_force_n = std::max(0.0, supervisor_.filtered_normal_force_n());
    measured.normal_displacement_m = last_normal_displacement_m_;
    measured.lateral_position_m = last_lateral_position_m_;
    measured.lateral_force_n = supervisor_.filtered_lateral_force_n();
    sp_ = runner_.at(tick_, measured);
  }
  const ControlOutput out = controller_.step(sp_, frame_);
  const std::uint64_t t3 = now_ns();

  // Defence in depth: nothing non-finite or out of range reaches the
  // backend, whatever the validator and the controller did. A refused
  // command trips the run; the backend keeps the last drive written, from
  // which the stop sequence unloads.
  if (out.friction_compensated && !supervisor_.compensation_allowed(out.friction_compensation_n, tick_)) {
    if (!stopping_) start_stopping(RunEnd::kTripped);
  } else if (!supervisor_.command_allowed(out.drive, sp_.normal, sp_.lateral, !stopping_, tick_)) {
    if (!stopping_) start_stopping(RunEnd::kTripped);
  } else {
    written_ = out.drive;
    if (supervisor_.tripped() && !stopping_) start_stopping(RunEnd::kTripped);  // a non-finite setpoint
  }
  last_write_ = transducer_.write(written_);
  const std::uint64_t t4 = now_ns();
  // Acted on: the stop sequence's first drive is written.
  if (trip == TripReason::kEmergencyStop) {
    const std::uint64_t acted = timed_ ? t4 : config_.clock_ns();
    telemetry_.emergency_acted_ns.store(static_cast<std::int64_t>(acted), std::memory_order_relaxed);
  }

  std::uint32_t flags = out.flags;
  flags |= sample_flags_of_sensor_status(frame_.status_bits);
  if (read != hal::IoResult::kOk) flags |= v1::SENSOR_INVALID;
  if (stopping_) flags |= v1::SAFE_UNLOAD;
  if (supervisor_.tripped()) flags |= v1::SAFETY_TRIPPED;
  record(Sample{static_cast<double>(tick_) * period_s_, sp_.segment, out.normal_setpoint_n,
                frame_.normal_force_n, frame_.normal_displacement_m, out.lateral_setpoint_m,
                frame_.recorded_lateral_position_m(), frame_.lateral_force_n, flags},
         sp_.ticks_per_sample);
  const std::uint64_t t5 = now_ns();

  TickTiming& timing = telemetry_.timing;
  if (timed_) {
    timing.record(Stage::kRead, t1 - t0);
    timing.record(Stage::kSupervise, t2 - t1);
    timing.record(Stage::kControl, t3 - t2);
    timing.record(Stage::kWrite, t4 - t3);
    timing.record(Stage::kRecord, t5 - t4);
    timing.record(Stage::kTick, t5 - t0);
    timing.count_tick();  // the means are over the timed ticks
  }
  ++tick_;
  telemetry_.cycles.store(tick_, std::memory_order_relaxed);
  transducer_.wait_next_tick();
  return true;
}

std::uint64_t RunLoop::now_ns() const { return timed_ ? config_.clock_ns() : 0; }

RunOutcome execute_run(hal::Transducer& transducer, const LoadFunction& load_function,
                       const RunLoopConfig& config, SpscQueue<Sample>& queue, RunControl& control,
                       RunTelemetry& telemetry) {
  // Linux lets an ordinary thread's absolute-deadline sleep end up to 50 µs
  // late (timer slack); the loop thread asks for 1 ns (bench: BM_PacedJitter).
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  RunLoop loop(transducer, load_function, config, queue, control, telemetry);
  while (loop.tick()) {
  }
  return loop.outcome();
}

}  // namespace tribo::daemon
