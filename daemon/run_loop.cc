#include "daemon/run_loop.h"

#include <algorithm>
#include <thread>

#include "daemon/acquisition.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

namespace {

class SampleSink {
 public:
  SampleSink(SpscQueue<Sample>& queue, bool backpressure, RunTelemetry& telemetry)
      : queue_(queue), backpressure_(backpressure), telemetry_(telemetry) {}

  void add(const Sample& tick, std::uint32_t ticks_per_sample) {
    Sample recorded;
    if (!acquisition_.add(tick, ticks_per_sample, recorded)) return;
    while (!queue_.try_push(recorded)) {
      if (!backpressure_) {
        telemetry_.samples_dropped.fetch_add(1, std::memory_order_relaxed);
        return;
      }
      std::this_thread::yield();
    }
    telemetry_.samples.fetch_add(1, std::memory_order_relaxed);
  }

  bool at_sample_boundary() const { return acquisition_.empty(); }

 private:
  SpscQueue<Sample>& queue_;
  bool backpressure_;
  RunTelemetry& telemetry_;
  Acquisition acquisition_;
};

Sample tick_sample(double time_s, const Setpoints& sp, const hal::SensorFrame& f,
                   std::uint32_t flags) {
  return Sample{time_s,           sp.segment,        sp.normal_force_n,   f.normal_force_n,
                f.normal_displacement_m, sp.lateral_position_m, f.lateral_position_m,
                f.lateral_force_n, flags};
}

}  // namespace

RunOutcome execute_run(hal::Transducer& transducer, const LoadFunction& load_function,
                       const RunLoopConfig& config, SpscQueue<Sample>& queue,
                       const std::atomic<bool>& abort_requested, RunTelemetry& telemetry) {
  Controller controller(config.controller);
  SafetySupervisor supervisor(config.limits);
  SampleSink sink(queue, config.backpressure, telemetry);
  const double period = transducer.period_s();
  const double unload_step_n = config.unload_rate_n_per_s * period;

  RunOutcome outcome;
  std::size_t cursor = 0;
  Setpoints sp;
  bool stopping = false;
  std::uint32_t unloaded_ticks = 0;
  std::uint64_t tick = 0;
  for (;; ++tick) {
    if (!stopping && tick >= load_function.total_ticks()) break;
    // After a stop: end once a whole recorded sample has been taken unloaded.
    if (stopping && unloaded_ticks >= 2 * sp.ticks_per_sample && sink.at_sample_boundary()) break;
    if (!stopping) sp = load_function.at(tick, cursor);

    hal::SensorFrame sensors;
    transducer.read(sensors);
    const TripReason trip = supervisor.check(sensors);
    if (!stopping && (trip != TripReason::kNone || abort_requested.load(std::memory_order_relaxed))) {
      stopping = true;
      outcome.end = trip != TripReason::kNone ? RunEnd::kTripped : RunEnd::kAborted;
      outcome.trip = trip;
    }
    std::uint32_t flags = (sensors.status_bits & hal::kSubstepCapHit) ? v1::SUBSTEP_CAP_HIT : 0;
    if (stopping) {  // ramp the normal force down, hold the lateral position
      sp.normal_force_n = std::max(0.0, sp.normal_force_n - unload_step_n);
      if (sp.normal_force_n == 0.0) ++unloaded_ticks;
      flags |= v1::SAFE_UNLOAD;
    }

    const ControlOutput out = controller.step(sp, sensors);
    transducer.write(out.drive);
    sink.add(tick_sample(static_cast<double>(tick) * period, sp, sensors, flags | out.flags),
             sp.ticks_per_sample);
    telemetry.cycles.store(tick + 1, std::memory_order_relaxed);
    transducer.wait_next_tick();
  }
  outcome.cycles = tick;
  return outcome;
}

}  // namespace tribo::daemon
