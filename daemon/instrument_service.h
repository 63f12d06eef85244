// The daemon's core, independent of the transport: holds the loaded protocol
// and the one instrument backend, and tracks the state machine IDLE -> ARMED
// -> RUNNING -> ARMED (or FAULTED after a safety trip, an emergency stop, a
// failed recording, or at start-up after a run that did not finish).
//
// One long-lived, supervised loop thread owns the backend and hosts
// activities, one at a time: a protocol run (its real-time loop, safety
// supervisor and stop sequence; a drain thread records and publishes its
// samples), the autotune relay experiment, and the re-arm check. The API
// thread only posts: it never ticks the instrument. An emergency stop sets
// the running activity's flag and interrupts the backend's wait for the next
// tick (hal/tick_wake.h), so the activity acts on it at once, not at the
// next deadline. Run documents leave through RunEventSink.
#pragma once

#include <array>
#include <condition_variable>
#include <deque>
#include <functional>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "daemon/load_function.h"
#include "hal/last_drive_transducer.h"
#include "hal/transducer.h"
#include "tribo/v1/api.pb.h"

namespace tribo {
struct Sample;
}

namespace tribo::daemon {

struct RunOutcome;
struct AutotuneParams;
struct AutotuneResult;
class ActivityRecording;
template <typename T>
class SpscQueue;

// Receives run documents in order: start, descriptor, sample blocks
// interleaved with segment events (an event follows the samples before its
// sequence number), faults, stop. Called from the service's threads;
// implementations must not block for long.
class RunEventSink {
 public:
  virtual ~RunEventSink() = default;
  virtual void on_run_start(const v1::RunStart& start) = 0;
  virtual void on_samples(const v1::SampleBlock& block) = 0;
  virtual void on_run_stop(const v1::RunStop& stop) = 0;
  virtual void on_descriptor(const v1::RunDescriptor&) {}
  virtual void on_segment_event(const v1::SegmentEvent&) {}
  virtual void on_fault(const v1::Fault&) {}
};

class InstrumentService {
 public:
  InstrumentService(v1::DaemonConfig config, std::string software_version, RunEventSink& sink);
  ~InstrumentService();

  std::optional<v1::Error> load_protocol(const v1::Protocol& protocol, v1::LoadProtocolReply& reply);
  std::optional<v1::Error> start_run(std::optional<std::uint64_t> seed, v1::StartRunReply& reply,
                                     const v1::RunAnnotations& annotations = {});
  std::optional<v1::Error> abort_run(const std::string& reason);
  v1::StatusReply status() const;

  // Control and safety. Gains apply to the next runs and,
  // bumplessly, to the running one.
  std::optional<v1::Error> set_gains(v1::ControlLoop loop, const v1::PidGains& gains,
                                     v1::SetGainsReply& reply);
  v1::GetGainsReply gains() const;
  // FAULTED -> ARMED (or IDLE without a protocol) once the instrument's
  // present state is safe; the reply carries the measured values the next
  // run's setpoints start from. The check runs as an activity of the loop;
  // done is called from the loop thread with the outcome (immediately, on
  // this thread, when refused). An emergency stop during the check ends it
  // and the instrument stays FAULTED.
  using RearmDone = std::function<void(std::optional<v1::Error>, const v1::RearmReply&)>;
  void rearm_async(RearmDone done);
  // The same, waiting for the outcome (tests, tools).
  std::optional<v1::Error> rearm(v1::RearmReply& reply);
  // Trips the running run's supervisor (or stops the running activity), or
  // when idle latches FAULTED and posts the safe stop sequence from the drive
  // the instrument holds (daemon/idle_stop.h); the reply does not wait for it.
  std::optional<v1::Error> emergency_stop(const std::string& reason, v1::EmergencyStopReply& reply);
  // Relay autotune of the lateral displacement loop; not while running. It
  // runs as an activity of the loop; done is called from the loop thread
  // with the outcome (immediately, on this thread, when refused).
  using AutotuneDone = std::function<void(std::optional<v1::Error>, const v1::AutotuneReply&)>;
  void autotune_async(const v1::Autotune& request, AutotuneDone done);
  // The same, waiting for the outcome (tests, tools).
  std::optional<v1::Error> autotune(const v1::Autotune& request, v1::AutotuneReply& reply);

  // The latest emergency stop's latency: from its request to the tick of the
  // loop that acted on it (0: acted while idle; negative: none yet).
  double last_emergency_stop_latency_s() const;
  // The current or last run's recording failed.
  bool recording_failed() const {
    std::lock_guard lock(mutex_);
    return !recording_error_.empty();
  }

  // Aborts a running run (safe unload) and waits until it is recorded.
  void shutdown(const std::string& reason);
  // Waits until no run is active (tests).
  void wait_until_idle();

  const v1::DaemonConfig& config() const { return config_; }
  const std::string& software_version() const { return software_version_; }
  // "sim", ...: the configured transducer backend.
  std::string backend_name() const;

 private:
  struct ActiveRun;
  void run_main(ActiveRun& run);
  void drain_samples(ActiveRun& run);
  void join_finished_run();
  void latch_late_emergency_stop(ActiveRun& run, const RunOutcome& outcome);
  // The supervised loop: runs posted activities one at a time.
  void loop_main();
  // Queues an activity; the caller holds mutex_ and has set activity_.
  bool paced() const;  // the loop waits on the wall clock (never lock-step with a plant)
  void post_activity(std::function<void()> activity);
  // Waits (mutex_ held through lock) until no activity is queued or running.
  void wait_for_activities(std::unique_lock<std::mutex>& lock);
  // On the loop thread: reads the continuing instrument over several ticks.
  std::optional<std::string> rearm_check(v1::RearmReply& reply);
  void latch_incomplete_previous_run();
  // Posts the stop sequence from the last drive written; mutex_ held.
  void post_idle_stop();
  std::shared_ptr<ActivityRecording> start_autotune_recording(const AutotuneParams& params, std::string& error);
  v1::RunStop finish_autotune_recording(ActivityRecording& recording, const AutotuneResult& result);

  const v1::DaemonConfig config_;
  const std::string software_version_;
  RunEventSink& sink_;

  mutable std::mutex mutex_;  // guards everything below; never taken by the tick path
  v1::DaemonState state_ = v1::IDLE;
  std::optional<v1::Protocol> protocol_;
  LoadFunction load_function_;
  std::unique_ptr<ActiveRun> run_;
  // The runs' sample queue, made once: a run starts without allocating (and
  // touching) megabytes. Empty between runs: a run's drain ends on an empty queue.
  std::unique_ptr<SpscQueue<Sample>> run_samples_;
  std::string last_run_id_;
  std::uint64_t last_cycle_count_ = 0;
  std::array<v1::PidGains, 4> gains_;  // by ControlLoop - 1: the gains in force
  std::string trip_reason_;            // the latched (or last) trip
  double trip_time_s_ = 0;
  v1::StatusReply last_timing_;        // timing fields of the last run
  double loaded_duration_s_ = 0;
  struct DrainCounters {
    std::uint64_t recorded = 0, dropped = 0, sensor_invalid = 0;
    double time_s = 0;
  };
  DrainCounters last_counters_;  // of the last finished run
  v1::BackendHealth last_backend_health_;
  std::string recording_error_;  // of the current or last run; empty: healthy

  // The backend: created once, owned by the loop thread while an activity
  // runs; it remembers the last drive written, from which an idle emergency
  // stop unloads.
  std::unique_ptr<hal::LastDriveTransducer> transducer_;
  std::thread loop_thread_;
  std::condition_variable activity_cv_;  // with mutex_
  std::deque<std::function<void()>> pending_;
  std::string activity_;        // "run", "autotune", "re-arm check", "stop sequence"; empty: idle
  bool activity_running_ = false;
  std::string loop_scheduling_;        // set by the loop thread as it starts
  bool loop_exit_ = false;
  // Emergency stop (or shutdown) of activities other than a run (a run has
  // its RunControl): the autotune experiment and the re-arm check poll it
  // every tick, and the backend's wait is interrupted to make that tick now.
  std::atomic<bool> activity_stop_{false};
  std::string activity_stop_reason_;  // guarded by mutex_
  std::atomic<std::int64_t> estop_requested_ns_{-1};
  std::atomic<std::int64_t> estop_acted_ns_{-1};
};

}  // namespace tribo::daemon
