#include "daemon/instrument_service.h"

#include <sys/prctl.h>

#include <chrono>
#include <future>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/activity_recording.h"
#include "daemon/autotune.h"
#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/validation_messages.h"
#include "daemon/run_loop.h"
#include "daemon/field_bounds.h"
#include "daemon/idle_stop.h"
#include "daemon/incomplete_run.h"
#include "daemon/loop_scheduling.h"
#include "daemon/run_documents.h"
#include "proto/run_files.h"
#include "daemon/run_recorder.h"
#include "daemon/safety_supervisor.h"
#include "hal/backend_factory.h"

namespace tribo::daemon {

namespace {

constexpr std::size_t kQueueCapacity = 1 << 16;
constexpr int kBlockSamples = 1024;                        // samples per published block
constexpr auto kPublishInterval = std::chrono::milliseconds(50);  // or sooner when full

v1::Error make_error(v1::ErrorCode code, std::string field, std::string message) {
  v1::Error e;
  e.set_code(code);
  e.set_field(std::move(field));
  e.set_message(std::move(message));
  return e;
}

void fill_timing(const RunTelemetry& t, v1::StatusReply& s) {
  const double ticks = static_cast<double>(std::max<std::uint64_t>(1, t.timing.ticks()));
  for (std::size_t i = 0; i < kStageCount; ++i) {
    const auto stage = static_cast<Stage>(i);
    const StageSnapshot snap = t.timing.snapshot(stage);
    v1::StageTiming* st = s.add_stage_timings();
    st->set_stage(std::string(stage_name(stage)));
    st->set_last_us(static_cast<double>(snap.last_ns) * 1e-3);
    st->set_mean_us(static_cast<double>(snap.total_ns) * 1e-3 / ticks);
    st->set_max_us(static_cast<double>(snap.max_ns) * 1e-3);
    if (stage == Stage::kTick) s.set_max_tick_us(st->max_us());
  }
  s.set_overrun_count(t.overruns.load(std::memory_order_relaxed));
}

std::optional<Loop> loop_from_proto(v1::ControlLoop loop) {
  switch (loop) {
    case v1::LOOP_LATERAL_DISPLACEMENT: return Loop::kLateralDisplacement;
    case v1::LOOP_LATERAL_FORCE: return Loop::kLateralForce;
    case v1::LOOP_NORMAL_FORCE: return Loop::kNormalForce;
    case v1::LOOP_NORMAL_DISPLACEMENT: return Loop::kNormalDisplacement;
    default: return std::nullopt;
  }
}

}  // namespace

namespace {

// What the link did since `start` (counters are running totals).
hal::BackendHealth health_since(const hal::BackendHealth& now, const hal::BackendHealth& start) {
  hal::BackendHealth d = now;
  d.transactions -= std::min(now.transactions, start.transactions);
  d.timeouts -= std::min(now.timeouts, start.timeouts);
  d.exceptions -= std::min(now.exceptions, start.exceptions);
  d.bad_frames -= std::min(now.bad_frames, start.bad_frames);
  d.link_losses -= std::min(now.link_losses, start.link_losses);
  d.reconnect_attempts -= std::min(now.reconnect_attempts, start.reconnect_attempts);
  // The first failure of this run: none if nothing failed since the start,
  // the latest one if an earlier run had already set the first.
  if (d.errors() == 0 && d.reconnect_attempts == 0) {
    d.first_error.clear();
    d.last_error.clear();
  } else if (!start.first_error.empty()) {
    d.first_error = now.last_error;
  }
  return d;
}

}  // namespace

struct InstrumentService::ActiveRun {
  explicit ActiveRun(SpscQueue<Sample>& samples) : queue(samples) {}
  v1::RunStart start;
  hal::Transducer* transducer = nullptr;  // the service's backend, on the loop thread
  hal::BackendHealth health_at_start;     // guarded by the service mutex
  LoadFunction load_function;
  RunLoopConfig loop_config;
  SpscQueue<Sample>& queue;  // the service's run_samples_
  RunControl control;
  std::atomic<bool> loop_finished{false};
  std::string abort_reason;  // guarded by the service mutex
  std::string emergency_reason;  // guarded by the service mutex
  RunTelemetry telemetry;
  std::unique_ptr<RunRecorder> recorder;
  std::uint64_t published = 0;  // drain thread only
  // Drain thread: where the safe unload began (the fault's sequence).
  std::optional<std::uint64_t> unload_sequence;
  double unload_time_s = 0;
  // Published by the drain thread for status requests.
  std::atomic<std::uint64_t> recorded{0};
  std::atomic<std::uint64_t> sensor_invalid{0};
  std::atomic<double> latest_time_s{0};
};

namespace {

std::uint64_t unix_time_ns() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::system_clock::now().time_since_epoch())
                                        .count());
}

}  // namespace

std::string InstrumentService::backend_name() const { return hal::backend_name(config_); }

namespace {

std::int64_t monotonic_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

InstrumentService::InstrumentService(v1::DaemonConfig config, std::string software_version,
                                     RunEventSink& sink)
    : config_(std::move(config)),
      software_version_(std::move(software_version)),
      sink_(sink),
      run_samples_(std::make_unique<SpscQueue<Sample>>(kQueueCapacity)) {
  gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1] = config_.controller().lateral_displacement();
  gains_[v1::LOOP_LATERAL_FORCE - 1] = config_.controller().lateral_force();
  gains_[v1::LOOP_NORMAL_FORCE - 1] = config_.controller().normal_force();
  gains_[v1::LOOP_NORMAL_DISPLACEMENT - 1] = config_.controller().normal_displacement();
  // The instrument: one backend for the daemon's lifetime (hal/transducer.h).
  if (auto backend = hal::make_transducer(config_, config_.sim().seed())) {
    transducer_ = std::make_unique<hal::LastDriveTransducer>(std::move(backend));
  }
  latch_incomplete_previous_run();
  loop_thread_ = std::thread([this] { loop_main(); });
  // Status reports the loop's scheduling from the first request on.
  std::unique_lock lock(mutex_);
  activity_cv_.wait(lock, [this] { return !loop_scheduling_.empty(); });
}

InstrumentService::~InstrumentService() {
  shutdown("daemon shutting down");
  {
    std::lock_guard lock(mutex_);
    loop_exit_ = true;
  }
  activity_cv_.notify_all();
  if (loop_thread_.joinable()) loop_thread_.join();
}

// A run whose directory has no stop document was cut short (kill, crash,
// power): the tip may still be loaded. Come up latched until a re-arm has
// read the instrument, naming the samples that are lost.
void InstrumentService::latch_incomplete_previous_run() {
  const auto incomplete = find_incomplete_run(config_.recorder().data_dir());
  if (!incomplete) return;
  state_ = v1::FAULTED;
  trip_reason_ = incomplete->reason;
  spdlog::warn("{}", trip_reason_);
  if (!incomplete->document_error.empty()) spdlog::warn("{}", incomplete->document_error);
}

void InstrumentService::loop_main() {
  // Linux lets an ordinary thread's absolute-deadline sleep end up to 50 µs
  // late (timer slack); the loop thread asks for 1 ns (bench: BM_PacedJitter).
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  const auto& controller = config_.controller();
  LoopScheduling scheduling =
      apply_loop_scheduling(controller.loop_realtime_priority(), paced(),
                            controller.has_loop_cpu() ? std::optional<int>(controller.loop_cpu()) : std::nullopt);
  if (paced() && ((controller.loop_realtime_priority() > 0 && !scheduling.realtime) ||
                  scheduling.description.find("refused") != std::string::npos)) {
    spdlog::warn("loop thread: {}", scheduling.description);
  } else {
    spdlog::info("loop thread: {}", scheduling.description);
  }
  std::unique_lock lock(mutex_);
  loop_scheduling_ = std::move(scheduling.description);
  activity_cv_.notify_all();
  for (;;) {
    activity_cv_.wait(lock, [this] { return loop_exit_ || !pending_.empty(); });
    if (pending_.empty()) return;  // loop_exit_ and nothing left to do
    std::function<void()> activity = std::move(pending_.front());
    pending_.pop_front();
    activity_running_ = true;
    lock.unlock();
    activity();
    lock.lock();
    activity_running_ = false;
    if (pending_.empty()) activity_.clear();
    activity_cv_.notify_all();
  }
}

// A real backend runs on the wall clock; the simulated one only when asked.
bool InstrumentService::paced() const {
  return config_.backend_case() != v1::DaemonConfig::kSim || config_.controller().pace_to_wall_clock();
}

void InstrumentService::post_activity(std::function<void()> activity) {
  pending_.push_back(std::move(activity));
  activity_cv_.notify_all();
}

void InstrumentService::wait_for_activities(std::unique_lock<std::mutex>& lock) {
  activity_cv_.wait(lock, [this] { return pending_.empty() && !activity_running_; });
}

double InstrumentService::last_emergency_stop_latency_s() const {
  const std::int64_t requested = estop_requested_ns_.load(), acted = estop_acted_ns_.load();
  if (requested < 0) return -1;
  if (acted < requested) return 0;  // acted while idle: latched at once
  return static_cast<double>(acted - requested) * 1e-9;
}

std::optional<v1::Error> InstrumentService::load_protocol(const v1::Protocol& protocol,
                                                          v1::LoadProtocolReply& reply) {
  ProtocolCheck check = validate_protocol(protocol, config_);
  if (!check.ok()) return make_error(v1::INVALID_ARGUMENT, check.errors.front().field, describe_issues(check.errors));
  std::lock_guard lock(mutex_);
  if (state_ == v1::RUNNING) {
    return make_error(v1::WRONG_STATE, "", "a run is in progress; abort it before loading");
  }
  reply = dry_run_reply(protocol, check);
  protocol_ = protocol;
  load_function_ = std::move(check.load_function);
  loaded_duration_s_ = check.duration_s;
  if (state_ != v1::FAULTED) state_ = v1::ARMED;  // a fault needs an explicit re-arm
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::start_run(std::optional<std::uint64_t> seed,
                                                      v1::StartRunReply& reply,
                                                      const v1::RunAnnotations& annotations) {
  for (const auto& issue : check_field_bounds(annotations, "start_run.annotations", 1)) {
    return make_error(v1::INVALID_ARGUMENT, issue.field, issue.message);
  }
  std::unique_lock lock(mutex_);
  if (state_ == v1::RUNNING) return make_error(v1::WRONG_STATE, "", "a run is already in progress");
  if (state_ == v1::FAULTED) {
    return make_error(v1::WRONG_STATE, "",
                      "the instrument is faulted (" + trip_reason_ + "); re-arm it first");
  }
  if (!protocol_) return make_error(v1::WRONG_STATE, "", "no protocol loaded");
  if (!activity_.empty() && activity_ != "run") {
    return make_error(v1::WRONG_STATE, "", "the instrument is busy: " + activity_ + " in progress");
  }
  if (!transducer_) return make_error(v1::INTERNAL, "backend", "cannot create the backend");
  // The previous run may still be handing out its stop document.
  wait_for_activities(lock);
  join_finished_run();

  auto run = std::make_unique<ActiveRun>(*run_samples_);
  const std::uint64_t run_seed = seed.value_or(config_.sim().seed());
  v1::PidGains gains[4];
  for (int i = 0; i < 4; ++i) gains[i] = gains_[static_cast<std::size_t>(i)];
  run->start = make_run_start(*protocol_, config_, load_function_, gains, run_seed, software_version_, annotations);
  v1::RunStart& start = run->start;
  start.set_start_time_utc(utc_timestamp_iso8601());

  std::string error;
  run->recorder = RunRecorder::create(config_.recorder().data_dir(), start, error);
  if (!run->recorder) return make_error(v1::INTERNAL, "recorder.data_dir", error);
  run->transducer = transducer_.get();
  run->load_function = load_function_;
  run->loop_config = run_loop_config_from(start.config());
  // Only the simulated backend running as fast as possible may wait for the
  // consumer: its plant waits with it. Paced or real loops never wait.
  run->loop_config.backpressure = !paced();
  // An unpaced loop times its stages on one tick in kUnpacedTimingInterval:
  // status keeps its stage times, the run its speed.
  if (!paced()) run->loop_config.time_stages_every = kUnpacedTimingInterval;

  reply.set_run_id(start.run_id());
  last_run_id_ = start.run_id();
  state_ = v1::RUNNING;
  recording_error_.clear();
  v1::RunDescriptor descriptor = make_descriptor(load_function_);
  descriptor.set_run_id(start.run_id());
  run->recorder->describe(descriptor);
  sink_.on_run_start(start);
  sink_.on_descriptor(descriptor);
  spdlog::info("run {} started: protocol '{}', seed {}", start.run_id(),
               printable_prefix(protocol_->name(), 64), run_seed);
  run_ = std::move(run);
  activity_ = "run";
  post_activity([this, r = run_.get()] { run_main(*r); });
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::abort_run(const std::string& reason) {
  std::lock_guard lock(mutex_);
  if (state_ != v1::RUNNING || !run_) return make_error(v1::WRONG_STATE, "", "no run in progress");
  if (run_->control.abort_requested.load()) return std::nullopt;  // the first reason stands
  run_->abort_reason = reason.empty() ? "aborted by client" : reason;
  run_->control.abort_requested.store(true);
  return std::nullopt;
}

v1::StatusReply InstrumentService::status() const {
  std::lock_guard lock(mutex_);
  v1::StatusReply s;
  s.set_state(state_);
  s.set_run_id(last_run_id_);
  s.set_cycle_count(run_ ? run_->telemetry.cycles.load() : last_cycle_count_);
  if (protocol_) s.set_loaded_protocol(protocol_->name());
  DrainCounters counters = last_counters_;
  if (run_) {
    counters.recorded = run_->recorded.load();
    counters.dropped = run_->telemetry.samples_dropped.load();
    counters.sensor_invalid = run_->sensor_invalid.load();
    counters.time_s = run_->latest_time_s.load();
  }
  s.set_samples_recorded(counters.recorded);
  s.set_samples_dropped(counters.dropped);
  s.set_run_time_s(counters.time_s);
  s.set_run_duration_s(loaded_duration_s_);
  s.set_loop_scheduling(loop_scheduling_);
  // The link's own record plus what the recorded samples say.
  v1::BackendHealth* health = s.mutable_backend_health();
  *health = state_ == v1::RUNNING && run_ && run_->transducer
                ? health_message(run_->transducer->backend_name(),
                                 health_since(run_->transducer->health(), run_->health_at_start))
                : last_backend_health_;
  health->set_backend(backend_name());
  health->set_sensor_invalid_samples(counters.sensor_invalid);
  health->set_healthy(counters.sensor_invalid == 0 && health->first_error().empty());
  health->set_detail(counters.sensor_invalid == 0
                         ? "no invalid sensor reading in the current or last run"
                         : std::to_string(counters.sensor_invalid) +
                               " recorded samples flagged SENSOR_INVALID in the current or last run");
  if (run_) {
    fill_timing(run_->telemetry, s);
    if (run_->telemetry.tripped.load()) s.set_tripped(true);
  } else {
    s.MergeFrom(last_timing_);
  }
  if (state_ == v1::FAULTED) s.set_tripped(true);
  s.set_activity(activity_);
  if (!recording_error_.empty()) {
    s.set_recording_failed(true);
    s.set_recording_error(recording_error_);
    health->set_healthy(false);
    health->set_detail("the recording failed: " + recording_error_);
  }
  s.set_trip_reason(trip_reason_);
  s.set_trip_time_s(trip_time_s_);
  return s;
}

std::optional<v1::Error> InstrumentService::set_gains(v1::ControlLoop loop, const v1::PidGains& gains,
                                                      v1::SetGainsReply& reply) {
  const std::optional<Loop> which = loop_from_proto(loop);
  if (!which) return make_error(v1::INVALID_ARGUMENT, "set_gains.loop", "set_gains.loop is not set");
  if (auto e = validate_pid_gains("set_gains.gains", gains)) {
    return make_error(v1::INVALID_ARGUMENT, e->substr(0, e->find_first_of(" =")), *e);
  }
  std::lock_guard lock(mutex_);
  if (state_ == v1::RUNNING && run_) {
    // The loop applies it bumplessly at its next tick; the mutex keeps a single producer.
    if (!run_->control.gain_updates.try_push(GainUpdate{*which, pid_gains_from_proto(gains)})) {
      return make_error(v1::INTERNAL, "", "gain changes arrive faster than the loop applies them; retry");
    }
    reply.set_applied_to_running_run(true);
  }
  gains_[loop - 1] = gains;
  reply.set_loop(loop);
  *reply.mutable_gains() = gains;
  spdlog::info("gains of {} set: kp {} ki {} kd {}", v1::ControlLoop_Name(loop), gains.kp(), gains.ki(), gains.kd());
  return std::nullopt;
}

v1::GetGainsReply InstrumentService::gains() const {
  std::lock_guard lock(mutex_);
  v1::GetGainsReply reply;
  for (int loop = v1::LOOP_LATERAL_DISPLACEMENT; loop <= v1::LOOP_NORMAL_DISPLACEMENT; ++loop) {
    v1::LoopGains* g = reply.add_loops();
    g->set_loop(static_cast<v1::ControlLoop>(loop));
    *g->mutable_gains() = gains_[loop - 1];
  }
  return reply;
}

void InstrumentService::rearm_async(RearmDone done) {
  std::unique_lock lock(mutex_);
  const auto refuse = [&](v1::Error e) {
    lock.unlock();  // done may call the service again
    done(std::move(e), v1::RearmReply{});
  };
  if (state_ != v1::FAULTED) {
    return refuse(make_error(v1::WRONG_STATE, "", "re-arm is for a faulted instrument; the state is " +
                                                      v1::DaemonState_Name(state_)));
  }
  // A run or an idle stop sequence ends by itself: the check reads the instrument after it.
  if (!activity_.empty() && activity_ != "run" && activity_ != "stop sequence") {
    return refuse(make_error(v1::WRONG_STATE, "", "the instrument is busy: " + activity_ + " in progress"));
  }
  if (!transducer_) return refuse(make_error(v1::INTERNAL, "backend", "cannot create the backend"));
  wait_for_activities(lock);  // a faulted run may still be handing out its stop document
  // The check reads the instrument on the loop thread, which owns the
  // backend; this thread goes back to its other clients meanwhile.
  activity_stop_.store(false);
  activity_ = "re-arm check";
  post_activity([this, done = std::move(done)] {
    v1::RearmReply reply;
    std::optional<std::string> problem = rearm_check(reply);
    std::optional<v1::Error> error;
    {
      std::lock_guard inner(mutex_);
      // An emergency stop after the last tick of the check still counts.
      if (!problem && activity_stop_.load()) problem = "stopped during the check: " + activity_stop_reason_;
      if (problem) {
        error = make_error(v1::WRONG_STATE, "", "cannot re-arm: " + *problem + " (fault: " + trip_reason_ + ")");
        reply = v1::RearmReply{};
      } else {
        spdlog::info("re-armed after: {}", trip_reason_);
        state_ = protocol_ ? v1::ARMED : v1::IDLE;
      }
      activity_.clear();  // free before the reply goes out: a client may start at once
    }
    done(std::move(error), reply);
  });
}

std::optional<v1::Error> InstrumentService::rearm(v1::RearmReply& reply) {
  std::promise<std::pair<std::optional<v1::Error>, v1::RearmReply>> outcome;
  auto future = outcome.get_future();
  rearm_async([&outcome](std::optional<v1::Error> e, const v1::RearmReply& r) { outcome.set_value({std::move(e), r}); });
  auto [error, result] = future.get();
  reply = std::move(result);
  return error;
}

// Reads the continuing instrument (no new session: the state it is in now)
// over kRearmTicks ticks, writing nothing: every read must answer with
// finite values that are not frozen, the mean lateral position inside the
// travel and the mean normal force below the unloaded threshold.
std::optional<std::string> InstrumentService::rearm_check(v1::RearmReply& reply) {
  constexpr int kRearmTicks = 64;
  const SupervisorParams p = supervisor_params_from_config(config_);
  hal::SensorFrame first, f;
  double sum[4] = {0, 0, 0, 0};
  bool changed[4] = {false, false, false, false};
  for (int k = 0; k < kRearmTicks; ++k) {
    if (k > 0) transducer_->wait_next_tick();
    if (activity_stop_.load(std::memory_order_relaxed)) {
      // Nothing to drive to safety: the check writes nothing.
      estop_acted_ns_.store(monotonic_now_ns());
      return "an emergency stop arrived during the check";
    }
    if (transducer_->read(f) != hal::IoResult::kOk) return "the backend does not answer";
    const double v[4] = {f.lateral_position_m, f.lateral_force_n, f.normal_force_n, f.normal_displacement_m};
    if (k == 0) first = f;
    const double v0[4] = {first.lateral_position_m, first.lateral_force_n, first.normal_force_n,
                          first.normal_displacement_m};
    for (int c = 0; c < 4; ++c) {
      if (!std::isfinite(v[c])) return "a sensor reading is not finite";
      sum[c] += v[c];
      if (v[c] != v0[c]) changed[c] = true;
    }
  }
  const bool per_channel = config_.supervisor().frozen_channel_ticks() > 0;
  const char* names[4] = {"lateral position", "lateral force", "normal force", "normal displacement"};
  if (!changed[0] && !changed[1] && !changed[2] && !changed[3]) {
    return fmt::format("all four sensor channels repeated the same values for {} ticks: the readout is frozen",
                       kRearmTicks);
  }
  for (int c = 0; per_channel && c < 4; ++c) {
    if (!changed[c]) {
      return fmt::format("the {} repeated the same value for {} ticks: frozen", names[c], kRearmTicks);
    }
  }
  const double x = sum[0] / kRearmTicks, lf = sum[1] / kRearmTicks, n = sum[2] / kRearmTicks,
               z = sum[3] / kRearmTicks;
  if (std::fabs(x) > p.max_lateral_travel_m) {
    return fmt::format("the lateral position {:g} m is beyond the travel {:g} m", x, p.max_lateral_travel_m);
  }
  if (std::fabs(n) > p.contact_force_n) {
    return fmt::format("the normal force {:g} N (mean of {} ticks) is above the unloaded threshold {:g} N", n,
                       kRearmTicks, p.contact_force_n);
  }
  reply.set_lateral_position_m(x);
  reply.set_lateral_force_n(lf);
  reply.set_normal_force_n(n);
  reply.set_normal_displacement_m(z);
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::emergency_stop(const std::string& reason,
                                                           v1::EmergencyStopReply& reply) {
  estop_requested_ns_.store(monotonic_now_ns());
  std::lock_guard lock(mutex_);
  const std::string why = reason.empty() ? "requested by a client" : printable_prefix(reason, kMaxTextBytes);
  if (state_ == v1::RUNNING && run_) {
    run_->emergency_reason = why;
    run_->control.emergency_stop.store(true);
    reply.set_run_was_active(true);
    // The loop may be asleep until the next deadline: wake it to act now.
    if (transducer_) transducer_->interrupt_wait();
  } else {
    if (!activity_.empty()) {
      // The autotune experiment or the re-arm check: it sees the flag at
      // the tick the wake starts and stops; the latch is set here.
      activity_stop_reason_ = why;
      activity_stop_.store(true);
      reply.set_run_was_active(true);
      if (transducer_) transducer_->interrupt_wait();
    } else {
      estop_acted_ns_.store(estop_requested_ns_.load());
      // Nothing runs, but the instrument may still hold a drive (a protocol
      // need not end unloaded): unload it, as a faulted run would.
      post_idle_stop();
    }
    state_ = v1::FAULTED;
    trip_reason_ = std::string(trip_reason_text(TripReason::kEmergencyStop)) + ": " + why;
    trip_time_s_ = 0;
  }
  spdlog::warn("emergency stop: {}", printable_prefix(why, 200));
  return std::nullopt;
}

void InstrumentService::post_idle_stop() {
  if (!transducer_) return;
  activity_ = "stop sequence";
  post_activity([this] {
    // On the loop thread: the drive the last activity left is final here.
    const hal::DriveCommand from = transducer_->last_drive();
    if (from.normal_force_n == 0 && from.lateral_force_n == 0) return;  // nothing held
    const IdleStopOutcome out = run_idle_stop(*transducer_, run_loop_config_from(config_), from, &estop_acted_ns_);
    spdlog::warn("emergency stop while idle: unloaded from normal {:g} N, lateral {:g} N in {} ticks{}{}",
                 from.normal_force_n, from.lateral_force_n, out.ticks,
                 out.command_refused ? "; a drive was refused, the rest not written" : "",
                 out.failed_writes ? fmt::format("; {} writes failed", out.failed_writes) : "");
  });
}

void InstrumentService::autotune_async(const v1::Autotune& request, AutotuneDone done) {
  AutotuneParams params;
  const auto refuse = [&](v1::Error e) { done(std::move(e), v1::AutotuneReply{}); };
  {
    std::unique_lock lock(mutex_);
    if (state_ == v1::RUNNING) return refuse(make_error(v1::WRONG_STATE, "", "a run is in progress"));
    if (state_ == v1::FAULTED) {
      return refuse(make_error(v1::WRONG_STATE, "", "the instrument is faulted (" + trip_reason_ + "); re-arm it first"));
    }
    if (!activity_.empty() && activity_ != "run") {
      return refuse(make_error(v1::WRONG_STATE, "", "the instrument is busy: " + activity_ + " in progress"));
    }
    if (!transducer_) return refuse(make_error(v1::INTERNAL, "backend", "cannot create the backend"));
    wait_for_activities(lock);  // a finished run may still be handing out its stop document
    const auto& c = config_.autotune();
    params.relay_amplitude_n = request.has_relay_amplitude_n() ? request.relay_amplitude_n() : c.relay_amplitude_n();
    params.hysteresis_m = request.has_hysteresis_m() ? request.hysteresis_m() : c.hysteresis_m();
    params.position_m = c.position_m();
    params.cycles = c.cycles();
    params.max_duration_s = c.max_duration_s();
    params.max_travel_m = config_.limits().max_lateral_travel_m();
    params.present = pid_gains_from_proto(gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1]);
    params.max_lateral_drive_n = supervisor_params_from_config(config_).lateral_drive_max_n;
    if (!(params.relay_amplitude_n > 0) || params.relay_amplitude_n > config_.limits().max_lateral_force_n()) {
      return refuse(make_error(v1::INVALID_ARGUMENT, "autotune.relay_amplitude_n",
                               "autotune.relay_amplitude_n must be in (0, " +
                                   std::to_string(config_.limits().max_lateral_force_n()) + "] N"));
    }
    if (!(params.hysteresis_m >= 0) || !std::isfinite(params.hysteresis_m)) {
      return refuse(make_error(v1::INVALID_ARGUMENT, "autotune.hysteresis_m",
                               "autotune.hysteresis_m must be finite and >= 0"));
    }
    params.stop_requested = &activity_stop_;
    params.stop_acted_ns = &estop_acted_ns_;
    // Recorded like a run: its own run directory, listed and fetchable.
    std::string recording_error;
    std::shared_ptr<ActivityRecording> recording = start_autotune_recording(params, recording_error);
    if (!recording) return refuse(make_error(v1::INTERNAL, "recorder.data_dir", recording_error));
    params.samples = &recording->queue();
    params.samples_dropped = &recording->dropped();
    activity_stop_.store(false);
    activity_ = "autotune";
    // The experiment moves the instrument: unloaded, outside any run, from a
    // fresh session (the simulated plant at rest with the config's seed).
    post_activity([this, params, recording, apply = request.apply(), done = std::move(done)] {
      transducer_->begin_session(config_.sim().seed());
      recording->start();
      const AutotuneResult result = relay_autotune(*transducer_, params);
      const v1::RunStop stop = finish_autotune_recording(*recording, result);
      v1::AutotuneReply reply;
      std::optional<v1::Error> error;
      const std::string recorded = " (recorded as run " + stop.run_id() + ")";
      if (result.emergency_stopped) {
        std::lock_guard lock(mutex_);
        error = make_error(v1::WRONG_STATE, "", "autotune stopped: emergency stop: " + activity_stop_reason_ + recorded);
      } else if (!result.ok) {
        if (result.command_refused) {
          std::lock_guard lock(mutex_);
          state_ = v1::FAULTED;
          trip_reason_ = std::string(trip_reason_text(TripReason::kCommandInvalid)) + " (autotune)";
        }
        error = make_error(v1::INTERNAL, "", "autotune failed: " + result.error + recorded);
      } else {
        reply.set_ultimate_gain_n_per_m(result.ultimate_gain_n_per_m);
        reply.set_ultimate_period_s(result.ultimate_period_s);
        reply.set_oscillation_amplitude_m(result.amplitude_m);
        reply.set_cycles(result.cycles);
        *reply.mutable_proposed() = pid_gains_to_proto(result.proposed);
        reply.set_rule(result.rule);
        spdlog::info("autotune: Ku {} N/m, Pu {} s, amplitude {} m", result.ultimate_gain_n_per_m,
                     result.ultimate_period_s, result.amplitude_m);
        if (apply) {
          v1::SetGainsReply applied;
          error = set_gains(v1::LOOP_LATERAL_DISPLACEMENT, reply.proposed(), applied);
          if (!error) reply.set_applied(true);
        }
      }
      {
        // Free before the reply goes out: a client may ask again at once.
        std::lock_guard lock(mutex_);
        activity_.clear();
      }
      done(std::move(error), reply);
    });
  }
}

// The caller holds mutex_ (the gains in force are read).
std::shared_ptr<ActivityRecording> InstrumentService::start_autotune_recording(const AutotuneParams& params,
                                                                               std::string& error) {
  v1::Protocol protocol;
  protocol.set_name("autotune");
  const std::uint32_t ticks_per_sample = params.ticks_per_sample;
  protocol.set_acquisition_rate_hz(config_.controller().loop_rate_hz() / ticks_per_sample);
  v1::PidGains gains[4];
  for (int i = 0; i < 4; ++i) gains[i] = gains_[static_cast<std::size_t>(i)];
  v1::RunStart start = make_run_start(protocol, config_, LoadFunction{}, gains, config_.sim().seed(),
                                      software_version_, v1::RunAnnotations{});
  start.set_start_time_utc(utc_timestamp_iso8601());
  v1::RunDescriptor descriptor = make_descriptor(LoadFunction{});
  descriptor.clear_duration_s();
  for (const char* name : kAutotuneSegmentNames) {
    start.add_segments()->set_name(name);
    descriptor.add_segment_names(name);
  }
  auto recording = ActivityRecording::create(config_.recorder().data_dir(), start, descriptor, error);
  if (!recording) return nullptr;
  spdlog::info("autotune recorded as run {}", recording->run_id());
  return std::shared_ptr<ActivityRecording>(std::move(recording));
}

// The stop document: SUCCESS with the result, FAULT after an emergency stop
// or a refused command (with the fault), ABORT when the experiment gave up.
v1::RunStop InstrumentService::finish_autotune_recording(ActivityRecording& recording, const AutotuneResult& result) {
  v1::RunStop stop;
  stop.set_cycle_count(result.ticks);
  std::optional<v1::Fault> fault;
  if (result.ok) {
    stop.set_exit_status(v1::SUCCESS);
    stop.set_reason(fmt::format("Ku {:g} N/m, Pu {:g} s, amplitude {:g} m; proposed kp {:g} ki {:g} kd {:g}",
                                result.ultimate_gain_n_per_m, result.ultimate_period_s, result.amplitude_m,
                                result.proposed.kp, result.proposed.ki, result.proposed.kd));
  } else if (result.emergency_stopped || result.command_refused) {
    stop.set_exit_status(v1::FAULT);
    std::string reason = result.error;
    if (result.emergency_stopped) {
      std::lock_guard lock(mutex_);
      reason = std::string(trip_reason_text(TripReason::kEmergencyStop)) + ": " + activity_stop_reason_ + " (" +
               result.error + ")";
    }
    stop.set_reason(reason);
    fault.emplace();
    fault->set_time_s(static_cast<double>(result.ticks) * transducer_->period_s());
    fault->set_reason(reason);
  } else {
    stop.set_exit_status(v1::ABORT);
    stop.set_reason("autotune failed: " + result.error);
  }
  const v1::RunStop written = recording.finish(stop, fault ? &*fault : nullptr);
  spdlog::info("autotune run {} stopped: {} ({} samples) {}", written.run_id(),
               v1::ExitStatus_Name(written.exit_status()), written.sample_count(), written.reason());
  return written;
}

std::optional<v1::Error> InstrumentService::autotune(const v1::Autotune& request, v1::AutotuneReply& reply) {
  std::promise<std::pair<std::optional<v1::Error>, v1::AutotuneReply>> outcome;
  auto future = outcome.get_future();
  autotune_async(request, [&outcome](std::optional<v1::Error> e, const v1::AutotuneReply& r) {
    outcome.set_value({std::move(e), r});
  });
  auto [error, result] = future.get();
  reply = std::move(result);
  return error;
}

void InstrumentService::run_main(ActiveRun& run) {
  // A new session of the one backend: the simulated plant at rest with the
  // run's seed (runs stay bit-identical), a real instrument as it is.
  {
    std::lock_guard lock(mutex_);
    run.health_at_start = run.transducer->health();
  }
  run.transducer->begin_session(run.start.seed());
  std::thread drain([this, &run] { drain_samples(run); });
  const RunOutcome outcome = execute_run(*run.transducer, run.load_function, run.loop_config,
                                         run.queue, run.control, run.telemetry);
  if (outcome.trip.reason == TripReason::kEmergencyStop) {
    estop_acted_ns_.store(run.telemetry.emergency_acted_ns.load());
  }
  run.loop_finished.store(true, std::memory_order_release);
  drain.join();

  v1::RunStop stop;
  stop.set_run_id(run.start.run_id());
  stop.set_sample_count(run.published);
  stop.set_cycle_count(outcome.cycles);
  stop.set_stop_time_utc(utc_timestamp_iso8601());
  std::string trip_text = trip_description(outcome.trip);
  if (outcome.trip.reason == TripReason::kEmergencyStop) {
    std::lock_guard lock(mutex_);
    if (!run.emergency_reason.empty()) {
      trip_text = std::string(trip_reason_text(TripReason::kEmergencyStop)) + ": " + run.emergency_reason;
    }
  }
  if (outcome.end == RunEnd::kTripped) {
    v1::Fault fault;
    fault.set_run_id(run.start.run_id());
    fault.set_sequence(run.unload_sequence.value_or(run.published));
    fault.set_time_s(run.unload_time_s);
    fault.set_reason(trip_text);
    run.recorder->record(fault);
    sink_.on_fault(fault);
  }
  {
    std::lock_guard lock(mutex_);
    switch (outcome.end) {
      case RunEnd::kCompleted:
        stop.set_exit_status(v1::SUCCESS);
        break;
      case RunEnd::kAborted:
        stop.set_exit_status(v1::ABORT);
        stop.set_reason(run.abort_reason);
        break;
      case RunEnd::kTripped:
        stop.set_exit_status(v1::FAULT);
        stop.set_reason(trip_text);
        break;
    }
  }
  // A real backend says what its link did; a run that did not complete
  // because of it records why.
  // The run's share of the link's record: the backend lives across runs.
  const hal::BackendHealth health = health_since(run.transducer->health(), run.health_at_start);
  *stop.mutable_backend_health() = health_message(run.transducer->backend_name(), health);
  if (outcome.end != RunEnd::kCompleted && !health.first_error.empty()) {
    stop.set_reason(stop.reason() + "; backend " + std::string(run.transducer->backend_name()) + ": " +
                    health.first_error);
  }
  if (health.errors() > 0 || health.max_io_s > 0) {
    spdlog::info("run {} backend {}: {} transactions, {} timeouts, {} exceptions, {} bad frames, {} link losses, "
                 "{} reconnect attempts, max I/O {:.3f} ms",
                 stop.run_id(), run.transducer->backend_name(), health.transactions, health.timeouts,
                 health.exceptions, health.bad_frames, health.link_losses, health.reconnect_attempts,
                 health.max_io_s * 1e3);
  }
  if (const auto dropped = run.telemetry.samples_dropped.load(); dropped > 0) {
    stop.set_reason(stop.reason() + (stop.reason().empty() ? "" : "; ") +
                    std::to_string(dropped) + " samples dropped: the recorder fell behind");
  }
  // A failed recording: which published samples are not on disk. finish()
  // writes the stop document even so (it is small and may still fit).
  const auto name_lost_range = [&] {
    if (!run.recorder->write_failed()) return;
    stop.set_recording_failed(true);
    stop.set_lost_first_sequence(run.recorder->written());
    stop.set_lost_end_sequence(run.published);
    const std::string lost = "recording failed (" + run.recorder->error() + "): samples [" +
                             std::to_string(run.recorder->written()) + ", " + std::to_string(run.published) +
                             ") are not in the recording";
    if (stop.reason().find(lost) == std::string::npos) {
      stop.set_reason(stop.reason() + (stop.reason().empty() ? "" : "; ") + lost);
    }
  };
  name_lost_range();
  if (!run.recorder->finish(stop)) {
    spdlog::error("run {}: writing the recording failed: {}", stop.run_id(), run.recorder->error());
    if (stop.exit_status() == v1::SUCCESS) stop.set_exit_status(v1::FAULT);
    name_lost_range();  // the failure may be the last block's
  }
  {
    // The state changes before the stop document goes out: a client that
    // starts the next run as soon as it sees it must find the daemon ready.
    std::lock_guard lock(mutex_);
    last_cycle_count_ = outcome.cycles;
    last_counters_ = DrainCounters{run.recorded.load(), run.telemetry.samples_dropped.load(),
                                   run.sensor_invalid.load(), run.latest_time_s.load()};
    last_backend_health_ = stop.backend_health();
    if (run.recorder->write_failed()) recording_error_ = run.recorder->error();
    activity_.clear();  // free for the next request as soon as the state says so
    state_ = stop.exit_status() == v1::FAULT ? v1::FAULTED : v1::ARMED;
    last_timing_.Clear();
    fill_timing(run.telemetry, last_timing_);
    if (stop.exit_status() == v1::FAULT) {
      trip_reason_ = stop.reason();
      trip_time_s_ = outcome.trip_time_s;
    }
    latch_late_emergency_stop(run, outcome);
  }
  spdlog::info("run {} stopped: {} ({} samples) {}", stop.run_id(), v1::ExitStatus_Name(stop.exit_status()),
               stop.sample_count(), stop.reason());
  sink_.on_run_stop(stop);
}

// An emergency stop that arrived after the loop's last tick, while the run
// was finishing (draining, writing its stop document), was seen by no tick:
// it still latches. The caller holds mutex_, as emergency_stop() does, so
// every request either reached the loop or is seen here.
void InstrumentService::latch_late_emergency_stop(ActiveRun& run, const RunOutcome& outcome) {
  if (!run.control.emergency_stop.load() || outcome.trip.reason == TripReason::kEmergencyStop) return;
  estop_acted_ns_.store(monotonic_now_ns());
  if (state_ == v1::FAULTED) return;  // already latched by another trip: its reason stands
  state_ = v1::FAULTED;
  trip_reason_ = std::string(trip_reason_text(TripReason::kEmergencyStop)) + ": " + run.emergency_reason +
                 " (after the run's last tick: the run had ended as " + std::string(v1::ExitStatus_Name(
                     outcome.end == RunEnd::kCompleted ? v1::SUCCESS : v1::ABORT)) + ")";
  trip_time_s_ = 0;
  spdlog::warn("emergency stop after run {}'s last tick: latched", run.start.run_id());
  post_idle_stop();  // a completed run may have left the tip loaded
}

// Records every sample, then publishes it: the recorder is flushed before a
// block goes out, so whatever a client has missed is already on disk. Segment
// events go out between the samples before and after them.
void InstrumentService::drain_samples(ActiveRun& run) {
  v1::SampleBlock block;
  auto last_publish = std::chrono::steady_clock::now();
  // A failed write stops the run (the loop trips at its next tick and
  // unloads); the samples keep going out to the clients, the only copy left.
  const auto check_recorder = [&] {
    if (run.recorder->write_failed() && !run.control.recording_failed.load(std::memory_order_relaxed)) {
      run.control.recording_failed.store(true, std::memory_order_relaxed);
      spdlog::error("run {}: {}; stopping the run", run.start.run_id(), run.recorder->error());
      std::lock_guard lock(mutex_);
      recording_error_ = run.recorder->error();
    }
  };
  const auto publish = [&] {
    if (sample_count(block) == 0) return;
    run.recorder->flush();
    check_recorder();
    block.set_run_id(run.start.run_id());
    block.set_first_sequence(run.published);
    run.published += sample_count(block);
    run.recorded.store(run.published, std::memory_order_relaxed);
    run.latest_time_s.store(block.time_s(sample_count(block) - 1), std::memory_order_relaxed);
    block.set_publish_time_unix_ns(unix_time_ns());
    sink_.on_samples(block);
    block.Clear();
    last_publish = std::chrono::steady_clock::now();
  };
  const auto segment_event = [&](v1::SegmentEventKind kind, const Sample& s, std::uint64_t sequence) {
    publish();
    const v1::SegmentEvent event =
        make_segment_event(run.start.run_id(), run.load_function, kind, s.segment_index, sequence, s.time_s);
    run.recorder->record(event);
    sink_.on_segment_event(event);
  };
  std::optional<std::uint32_t> segment;
  std::uint64_t sequence = 0;  // of the next sample popped
  for (;;) {
    const bool finished = run.loop_finished.load(std::memory_order_acquire);
    Sample s;
    bool any = false;
    while (run.queue.try_pop(s)) {
      any = true;
      const bool unloading = (s.status_flags & v1::SAFE_UNLOAD) != 0;
      if (unloading && !run.unload_sequence) {
        run.unload_sequence = sequence;
        run.unload_time_s = s.time_s;
        segment_event(v1::UNLOAD_BEGIN, s, sequence);
      } else if (!unloading && segment != s.segment_index) {
        segment_event(v1::SEGMENT_BEGIN, s, sequence);
      }
      segment = s.segment_index;
      if (s.status_flags & v1::SENSOR_INVALID) run.sensor_invalid.fetch_add(1, std::memory_order_relaxed);
      run.recorder->append(s);
      append_sample(s, block);
      ++sequence;
      if (sample_count(block) >= kBlockSamples) publish();
    }
    if (finished) break;  // everything pushed before the flag was set is drained
    if (std::chrono::steady_clock::now() - last_publish >= kPublishInterval) publish();
    if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  publish();
}

// The caller holds mutex_ with no activity running.
void InstrumentService::join_finished_run() { run_.reset(); }

void InstrumentService::shutdown(const std::string& reason) {
  {
    std::lock_guard lock(mutex_);
    if (run_ && state_ == v1::RUNNING) {
      run_->abort_reason = reason;
      run_->control.abort_requested.store(true);
    }
    if (!activity_.empty() && activity_ != "run") {
      activity_stop_reason_ = reason;
      activity_stop_.store(true);
    }
    if (transducer_ && !activity_.empty()) transducer_->interrupt_wait();
  }
  wait_until_idle();
}

void InstrumentService::wait_until_idle() {
  std::unique_lock lock(mutex_);
  wait_for_activities(lock);
  run_.reset();
}

}  // namespace tribo::daemon
