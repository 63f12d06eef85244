// The real-time loop of one run. Each tick:
//
//   read      the sensors through the HAL (a failed read keeps the last frame)
//   supervise apply pending gain changes; the supervisor checks the reading,
//             the applied drive and the link (daemon/safety_supervisor.h)
//   control   setpoints from the segment runner, or from the safe stop
//             sequence once stopping; the controller computes the drive
//   write     the drive to the HAL, after the supervisor's last check of
//             the command (finite, within the amplifier's range)
//   record    the tick into the acquisition filter; finished samples leave
//             through the SPSC queue
//   wait      the HAL's clock: lock-step plant step or absolute-deadline sleep
//
// It allocates nothing, takes no lock and does no I/O after construction
// (tests/daemon/tick_allocation_test.cc counts). On an abort request, an
// emergency stop or a safety trip the loop stops the segment runner and runs
// the safe stop sequence (daemon/stop_sequence.h), then the run ends.
#pragma once

#include <atomic>
#include <cstdint>

#include "daemon/controller.h"
#include "daemon/load_function.h"
#include "daemon/safety_supervisor.h"
#include "daemon/sample_queue.h"
#include "daemon/stop_sequence.h"
#include "daemon/tick_timing.h"
#include "daemon/acquisition.h"
#include "hal/transducer.h"
#include "proto/sample_record.h"

namespace tribo::daemon {

// tribod's unpaced simulated runs time one tick in this many.
inline constexpr std::uint32_t kUnpacedTimingInterval = 1024;

struct RunLoopConfig {
  ControllerParams controller;
  SupervisorParams supervisor;
  StopSequenceParams stop;
  // true: when the queue is full, wait for the consumer (the simulated plant
  // waits with us); false: count the sample as dropped and go on.
  bool backpressure = true;
  // The loop times the stages (six clock reads) of one tick in this many for
  // status requests (RunTelemetry::timing: maxima and means over the timed
  // ticks). 1: every tick (tribod's paced loops); kUnpacedTimingInterval:
  // tribod's simulated backend unpaced; 0: never, no clock read at all (an
  // acted-on emergency stop excepted): in-process runs (tribo_native.simulate,
  // campaigns). Six reads cost ~150 ns a tick, as much as half the simulated
  // instrument itself.
  std::uint32_t time_stages_every = 1;
  // The clock read for the stage times; a test counts its reads through it.
  std::uint64_t (*clock_ns)() = &monotonic_ns;
};

RunLoopConfig run_loop_config_from(const v1::DaemonConfig& config);

struct GainUpdate {
  Loop loop = Loop::kLateralDisplacement;
  PidGains gains;
};

// Requests from other threads to the loop; all lock-free.
struct RunControl {
  std::atomic<bool> abort_requested{false};
  std::atomic<bool> emergency_stop{false};
  // The recorder could not write (full disk, I/O error): the run stops as a
  // FAULT through the safe stop sequence.
  std::atomic<bool> recording_failed{false};
  // One producer at a time (the service pushes under its mutex).
  SpscQueue<GainUpdate> gain_updates{16};
};

// What the loop publishes for status requests from other threads.
struct RunTelemetry {
  std::atomic<std::uint64_t> cycles{0};
  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint64_t> samples_dropped{0};
  std::atomic<std::uint64_t> overruns{0};
  std::atomic<bool> tripped{false};
  // Monotonic time (ns) of the tick that acted on an emergency stop.
  std::atomic<std::int64_t> emergency_acted_ns{0};
  TickTiming timing;
};

enum class RunEnd { kCompleted, kAborted, kTripped };

struct RunOutcome {
  RunEnd end = RunEnd::kCompleted;
  Trip trip;
  std::uint64_t cycles = 0;
  double trip_time_s = 0;
};

// reason text + ": " + detail, e.g. "lateral force beyond the limit: filtered ..."
std::string trip_description(const Trip& trip);

// The sample status flags (v1::StatusFlag) a backend's sensor status bits
// (hal::SensorStatus) raise.
std::uint32_t sample_flags_of_sensor_status(std::uint32_t status_bits);

class RunLoop {
 public:
  RunLoop(hal::Transducer& transducer, const LoadFunction& load_function,
          const RunLoopConfig& config, SpscQueue<Sample>& queue, RunControl& control,
          RunTelemetry& telemetry);

  // One tick; false once the run has ended (then outcome() is final).
  bool tick();
  const RunOutcome& outcome() const { return outcome_; }

  const Controller& controller() const { return controller_; }
  const SafetySupervisor& supervisor() const { return supervisor_; }
  const StopSequence& stop_sequence() const { return stop_; }

 private:
  void start_stopping(RunEnd end);
  void finish();
  void record(const Sample& tick_sample, std::uint32_t ticks_per_sample);
  // The stage clock on a timed tick, else 0 without reading any clock.
  std::uint64_t now_ns() const;

  hal::Transducer& transducer_;
  SegmentRunner runner_;
  RunLoopConfig config_;
  SpscQueue<Sample>& queue_;
  RunControl& control_;
  RunTelemetry& telemetry_;
  Controller controller_;
  SafetySupervisor supervisor_;
  StopSequence stop_;
  Acquisition acquisition_;
  double period_s_;

  RunOutcome outcome_;
  bool finished_ = false;
  bool stopping_ = false;
  std::uint64_t tick_ = 0;
  bool timed_ = false;  // this tick times its stages
  hal::SensorFrame frame_;
  double last_lateral_position_m_ = 0;
  double last_normal_displacement_m_ = 0;
  hal::IoResult last_write_ = hal::IoResult::kOk;
  hal::DriveCommand written_;  // the last drive written to the backend
  TickSetpoints sp_;
};

RunOutcome execute_run(hal::Transducer& transducer, const LoadFunction& load_function,
                       const RunLoopConfig& config, SpscQueue<Sample>& queue, RunControl& control,
                       RunTelemetry& telemetry);

}  // namespace tribo::daemon
