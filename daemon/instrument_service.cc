#include "daemon/instrument_service.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include <spdlog/spdlog.h>

#include "daemon/autotune.h"
#include "daemon/controller.h"
#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_loop.h"
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

v1::BackendHealth health_message(std::string_view backend, const hal::BackendHealth& h) {
  v1::BackendHealth m;
  m.set_backend(std::string(backend));
  m.set_connected(h.connected);
  m.set_transactions(h.transactions);
  m.set_timeouts(h.timeouts);
  m.set_exceptions(h.exceptions);
  m.set_bad_frames(h.bad_frames);
  m.set_link_losses(h.link_losses);
  m.set_reconnect_attempts(h.reconnect_attempts);
  m.set_last_io_s(h.last_io_s);
  m.set_max_io_s(h.max_io_s);
  m.set_last_error(h.last_error);
  m.set_first_error(h.first_error);
  return m;
}

}  // namespace

struct InstrumentService::ActiveRun {
  v1::RunStart start;
  std::unique_ptr<hal::Transducer> transducer;
  LoadFunction load_function;
  RunLoopConfig loop_config;
  SpscQueue<Sample> queue{kQueueCapacity};
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

v1::RunDescriptor make_descriptor(const LoadFunction& load_function) {
  v1::RunDescriptor d;
  describe_channels(d);
  d.set_expected_samples(load_function.expected_samples());
  d.set_duration_s(static_cast<double>(load_function.total_ticks()) / load_function.loop_rate_hz());
  // segment_index counts the unrolled segments (repeat blocks expanded).
  for (const SegmentPlan& plan : load_function.segments()) d.add_segment_names(plan.name);
  return d;
}

}  // namespace

std::string InstrumentService::backend_name() const { return hal::backend_name(config_); }

InstrumentService::InstrumentService(v1::DaemonConfig config, std::string software_version,
                                     RunEventSink& sink)
    : config_(std::move(config)), software_version_(std::move(software_version)), sink_(sink) {
  gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1] = config_.controller().lateral_displacement();
  gains_[v1::LOOP_LATERAL_FORCE - 1] = config_.controller().lateral_force();
  gains_[v1::LOOP_NORMAL_FORCE - 1] = config_.controller().normal_force();
  gains_[v1::LOOP_NORMAL_DISPLACEMENT - 1] = config_.controller().normal_displacement();
}

InstrumentService::~InstrumentService() { shutdown("daemon shutting down"); }

std::optional<v1::Error> InstrumentService::load_protocol(const v1::Protocol& protocol,
                                                          v1::LoadProtocolReply& reply) {
  ProtocolCheck check = validate_protocol(protocol, config_);
  if (!check.ok()) {
    std::string message = check.errors.front().message;
    if (check.errors.size() > 1) {
      message += " (and " + std::to_string(check.errors.size() - 1) + " more:";
      for (std::size_t i = 1; i < check.errors.size(); ++i) message += " " + check.errors[i].message + ";";
      message += ")";
    }
    return make_error(v1::INVALID_ARGUMENT, check.errors.front().field, message);
  }
  std::lock_guard lock(mutex_);
  if (state_ == v1::RUNNING) {
    return make_error(v1::WRONG_STATE, "", "a run is in progress; abort it before loading");
  }
  protocol_ = protocol;
  load_function_ = std::move(check.load_function);
  loaded_duration_s_ = check.duration_s;
  if (state_ != v1::FAULTED) state_ = v1::ARMED;  // a fault needs an explicit re-arm
  reply.set_protocol_name(protocol.name());
  reply.set_duration_s(check.duration_s);
  reply.set_expected_samples(load_function_.expected_samples());
  for (auto& w : check.warnings) reply.add_warnings(std::move(w));
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::start_run(std::optional<std::uint64_t> seed,
                                                      v1::StartRunReply& reply) {
  std::lock_guard lock(mutex_);
  if (state_ == v1::RUNNING) return make_error(v1::WRONG_STATE, "", "a run is already in progress");
  if (state_ == v1::FAULTED) {
    return make_error(v1::WRONG_STATE, "",
                      "the instrument is faulted (" + trip_reason_ + "); re-arm it first");
  }
  if (!protocol_) return make_error(v1::WRONG_STATE, "", "no protocol loaded");
  join_finished_run();

  auto run = std::make_unique<ActiveRun>();
  const std::uint64_t run_seed = seed.value_or(config_.sim().seed());
  v1::RunStart& start = run->start;
  *start.mutable_protocol() = *protocol_;
  *start.mutable_config() = config_;
  start.mutable_config()->mutable_server()->clear_control_token();  // the run documents are public
  *start.mutable_lateral_gains() = gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1];
  // The gains in force (SetGains) go into the recorded config too.
  auto& recorded = *start.mutable_config()->mutable_controller();
  *recorded.mutable_lateral_displacement() = gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1];
  *recorded.mutable_lateral_force() = gains_[v1::LOOP_LATERAL_FORCE - 1];
  *recorded.mutable_normal_force() = gains_[v1::LOOP_NORMAL_FORCE - 1];
  *recorded.mutable_normal_displacement() = gains_[v1::LOOP_NORMAL_DISPLACEMENT - 1];
  start.set_seed(run_seed);
  start.set_software_version(software_version_);
  start.set_start_time_utc(utc_timestamp_iso8601());
  start.set_loop_rate_hz(config_.controller().loop_rate_hz());
  for (const SegmentPlan& plan : load_function_.segments()) {
    v1::RunSegment* seg = start.add_segments();
    seg->set_name(plan.name);
    seg->set_start_s(static_cast<double>(plan.start_tick) / load_function_.loop_rate_hz());
    seg->set_duration_s(static_cast<double>(plan.tick_count) / load_function_.loop_rate_hz());
    seg->set_normal_mode(plan.normal_mode == NormalMode::kClosedLoopForce ? v1::NORMAL_CLOSED_LOOP_FORCE
                         : plan.normal_mode == NormalMode::kDisplacement  ? v1::NORMAL_DISPLACEMENT
                                                                          : v1::NORMAL_OPEN_LOOP_FORCE);
    seg->set_lateral_mode(plan.lateral_mode == LateralMode::kForce ? v1::LATERAL_FORCE : v1::LATERAL_DISPLACEMENT);
  }

  std::string error;
  run->recorder = RunRecorder::create(config_.recorder().data_dir(), start, error);
  if (!run->recorder) return make_error(v1::INTERNAL, "recorder.data_dir", error);
  run->transducer = hal::make_transducer(config_, run_seed);
  if (!run->transducer) return make_error(v1::INTERNAL, "backend", "cannot create the backend");
  run->load_function = load_function_;
  run->loop_config = run_loop_config_from(start.config());
  // Only the simulated backend running as fast as possible may wait for the
  // consumer: its plant waits with it. Paced or real loops never wait.
  run->loop_config.backpressure =
      config_.backend_case() == v1::DaemonConfig::kSim && !config_.controller().pace_to_wall_clock();

  reply.set_run_id(start.run_id());
  last_run_id_ = start.run_id();
  state_ = v1::RUNNING;
  v1::RunDescriptor descriptor = make_descriptor(load_function_);
  descriptor.set_run_id(start.run_id());
  run->recorder->describe(descriptor);
  sink_.on_run_start(start);
  sink_.on_descriptor(descriptor);
  spdlog::info("run {} started: protocol '{}', seed {}", start.run_id(), protocol_->name(), run_seed);
  run_ = std::move(run);
  run_thread_ = std::thread([this, r = run_.get()] { run_main(*r); });
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
  // The link's own record (issue 6) plus what the recorded samples say.
  v1::BackendHealth* health = s.mutable_backend_health();
  *health = run_ && run_->transducer
                ? health_message(run_->transducer->backend_name(), run_->transducer->health())
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

std::optional<v1::Error> InstrumentService::rearm(v1::RearmReply& reply) {
  std::lock_guard lock(mutex_);
  if (state_ != v1::FAULTED) {
    return make_error(v1::WRONG_STATE, "", "re-arm is for a faulted instrument; the state is " +
                                               v1::DaemonState_Name(state_));
  }
  join_finished_run();
  // Read the instrument as it is now, through a fresh backend session.
  auto transducer = hal::make_transducer(config_, config_.sim().seed());
  if (!transducer) return make_error(v1::INTERNAL, "backend", "cannot create the backend");
  hal::SensorFrame f;
  const hal::IoResult read = transducer->read(f);
  const SupervisorParams p = supervisor_params_from_config(config_);
  std::string problem;
  char text[200];
  if (read != hal::IoResult::kOk) {
    problem = "the backend does not answer";
  } else if (!std::isfinite(f.lateral_position_m) || !std::isfinite(f.lateral_force_n) ||
             !std::isfinite(f.normal_force_n) || !std::isfinite(f.normal_displacement_m)) {
    problem = "a sensor reading is not finite";
  } else if (std::fabs(f.lateral_position_m) > p.max_lateral_travel_m) {
    std::snprintf(text, sizeof text, "the lateral position %g m is beyond the travel %g m",
                  f.lateral_position_m, p.max_lateral_travel_m);
    problem = text;
  } else if (std::fabs(f.normal_force_n) > p.contact_force_n) {
    std::snprintf(text, sizeof text, "the normal force %g N is above the unloaded threshold %g N",
                  f.normal_force_n, p.contact_force_n);
    problem = text;
  }
  if (!problem.empty()) {
    return make_error(v1::WRONG_STATE, "", "cannot re-arm: " + problem + " (fault: " + trip_reason_ + ")");
  }
  reply.set_lateral_position_m(f.lateral_position_m);
  reply.set_lateral_force_n(f.lateral_force_n);
  reply.set_normal_force_n(f.normal_force_n);
  reply.set_normal_displacement_m(f.normal_displacement_m);
  spdlog::info("re-armed after: {}", trip_reason_);
  state_ = protocol_ ? v1::ARMED : v1::IDLE;
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::emergency_stop(const std::string& reason,
                                                           v1::EmergencyStopReply& reply) {
  std::lock_guard lock(mutex_);
  const std::string why = reason.empty() ? "requested by a client" : reason;
  if (state_ == v1::RUNNING && run_) {
    run_->emergency_reason = why;
    run_->control.emergency_stop.store(true);
    reply.set_run_was_active(true);
  } else {
    state_ = v1::FAULTED;
    trip_reason_ = std::string(trip_reason_text(TripReason::kEmergencyStop)) + ": " + why;
    trip_time_s_ = 0;
  }
  spdlog::warn("emergency stop: {}", why);
  return std::nullopt;
}

std::optional<v1::Error> InstrumentService::autotune(const v1::Autotune& request,
                                                     v1::AutotuneReply& reply) {
  AutotuneParams params;
  {
    std::lock_guard lock(mutex_);
    if (state_ == v1::RUNNING) return make_error(v1::WRONG_STATE, "", "a run is in progress");
    if (state_ == v1::FAULTED) {
      return make_error(v1::WRONG_STATE, "", "the instrument is faulted (" + trip_reason_ + "); re-arm it first");
    }
    join_finished_run();
    const auto& c = config_.autotune();
    params.relay_amplitude_n = request.has_relay_amplitude_n() ? request.relay_amplitude_n() : c.relay_amplitude_n();
    params.hysteresis_m = request.has_hysteresis_m() ? request.hysteresis_m() : c.hysteresis_m();
    params.position_m = c.position_m();
    params.cycles = c.cycles();
    params.max_duration_s = c.max_duration_s();
    params.max_travel_m = config_.limits().max_lateral_travel_m();
    params.present = pid_gains_from_proto(gains_[v1::LOOP_LATERAL_DISPLACEMENT - 1]);
  }
  if (!(params.relay_amplitude_n > 0) || params.relay_amplitude_n > config_.limits().max_lateral_force_n()) {
    return make_error(v1::INVALID_ARGUMENT, "autotune.relay_amplitude_n",
                      "autotune.relay_amplitude_n must be in (0, " +
                          std::to_string(config_.limits().max_lateral_force_n()) + "] N");
  }
  if (!(params.hysteresis_m >= 0)) {
    return make_error(v1::INVALID_ARGUMENT, "autotune.hysteresis_m", "autotune.hysteresis_m must be >= 0");
  }
  // The experiment moves the instrument: it runs on a backend session of its
  // own, unloaded, outside any run (the I/O thread waits for it).
  auto transducer = hal::make_transducer(config_, config_.sim().seed());
  if (!transducer) return make_error(v1::INTERNAL, "backend", "cannot create the backend");
  const AutotuneResult result = relay_autotune(*transducer, params);
  if (!result.ok) return make_error(v1::INTERNAL, "", "autotune failed: " + result.error);
  reply.set_ultimate_gain_n_per_m(result.ultimate_gain_n_per_m);
  reply.set_ultimate_period_s(result.ultimate_period_s);
  reply.set_oscillation_amplitude_m(result.amplitude_m);
  reply.set_cycles(result.cycles);
  *reply.mutable_proposed() = pid_gains_to_proto(result.proposed);
  reply.set_rule(result.rule);
  spdlog::info("autotune: Ku {} N/m, Pu {} s, amplitude {} m", result.ultimate_gain_n_per_m,
               result.ultimate_period_s, result.amplitude_m);
  if (request.apply()) {
    v1::SetGainsReply applied;
    if (auto e = set_gains(v1::LOOP_LATERAL_DISPLACEMENT, reply.proposed(), applied)) return e;
    reply.set_applied(true);
  }
  return std::nullopt;
}

void InstrumentService::run_main(ActiveRun& run) {
  std::thread drain([this, &run] { drain_samples(run); });
  const RunOutcome outcome = execute_run(*run.transducer, run.load_function, run.loop_config,
                                         run.queue, run.control, run.telemetry);
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
  const hal::BackendHealth health = run.transducer->health();
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
  if (!run.recorder->finish(stop)) {
    spdlog::error("run {}: writing the recording failed", stop.run_id());
  }
  {
    // The state changes before the stop document goes out: a client that
    // starts the next run as soon as it sees it must find the daemon ready.
    std::lock_guard lock(mutex_);
    last_cycle_count_ = outcome.cycles;
    last_counters_ = DrainCounters{run.recorded.load(), run.telemetry.samples_dropped.load(),
                                   run.sensor_invalid.load(), run.latest_time_s.load()};
    last_backend_health_ = stop.backend_health();
    state_ = outcome.end == RunEnd::kTripped ? v1::FAULTED : v1::ARMED;
    last_timing_.Clear();
    fill_timing(run.telemetry, last_timing_);
    if (outcome.end == RunEnd::kTripped) {
      trip_reason_ = stop.reason();
      trip_time_s_ = outcome.trip_time_s;
    }
  }
  spdlog::info("run {} stopped: {} ({} samples) {}", stop.run_id(), v1::ExitStatus_Name(stop.exit_status()),
               stop.sample_count(), stop.reason());
  sink_.on_run_stop(stop);
}

// Records every sample, then publishes it: the recorder is flushed before a
// block goes out, so whatever a client has missed is already on disk. Segment
// events go out between the samples before and after them.
void InstrumentService::drain_samples(ActiveRun& run) {
  v1::SampleBlock block;
  auto last_publish = std::chrono::steady_clock::now();
  const auto publish = [&] {
    if (sample_count(block) == 0) return;
    run.recorder->flush();
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
    v1::SegmentEvent event;
    event.set_run_id(run.start.run_id());
    event.set_sequence(sequence);
    event.set_time_s(s.time_s);
    event.set_kind(kind);
    event.set_segment_index(s.segment_index);
    const auto& segments = run.start.protocol().segments();
    if (static_cast<int>(s.segment_index) < segments.size()) {
      event.set_segment_name(segments[static_cast<int>(s.segment_index)].name());
    }
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

void InstrumentService::join_finished_run() {
  if (run_thread_.joinable()) run_thread_.join();
  run_.reset();
}

void InstrumentService::shutdown(const std::string& reason) {
  {
    std::lock_guard lock(mutex_);
    if (run_ && state_ == v1::RUNNING) {
      run_->abort_reason = reason;
      run_->control.abort_requested.store(true);
    }
  }
  wait_until_idle();
}

void InstrumentService::wait_until_idle() {
  std::thread finished;
  {
    std::lock_guard lock(mutex_);
    finished = std::move(run_thread_);
  }
  if (finished.joinable()) finished.join();
  std::lock_guard lock(mutex_);
  run_.reset();
}

}  // namespace tribo::daemon
