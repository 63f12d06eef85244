// The real-time loop of one run: read sensors, supervise, control, write the
// drive, hand the sample on, wait for the next tick. It allocates nothing,
// takes no lock and does no I/O; samples leave through the SPSC queue.
//
// On an abort request or a safety trip the loop stops the load function and
// unloads: the normal force setpoint ramps to zero at unload_rate_n_per_s
// while the lateral position is held, then the run ends.
#pragma once

#include <atomic>
#include <cstdint>

#include "daemon/controller.h"
#include "daemon/load_function.h"
#include "daemon/safety_supervisor.h"
#include "daemon/sample_queue.h"
#include "hal/transducer.h"
#include "proto/sample_record.h"

namespace tribo::daemon {

struct RunLoopConfig {
  ControllerParams controller;
  SafetyLimits limits;
  double unload_rate_n_per_s = 10e-3;
  // true: when the queue is full, wait for the consumer (the simulated plant
  // waits with us); false: count the sample as dropped and go on.
  bool backpressure = true;
};

// Counters the loop publishes for status requests from other threads.
struct RunTelemetry {
  std::atomic<std::uint64_t> cycles{0};
  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint64_t> samples_dropped{0};
};

enum class RunEnd { kCompleted, kAborted, kTripped };

struct RunOutcome {
  RunEnd end = RunEnd::kCompleted;
  TripReason trip = TripReason::kNone;
  std::uint64_t cycles = 0;
};

RunOutcome execute_run(hal::Transducer& transducer, const LoadFunction& load_function,
                       const RunLoopConfig& config, SpscQueue<Sample>& queue,
                       const std::atomic<bool>& abort_requested, RunTelemetry& telemetry);

}  // namespace tribo::daemon
