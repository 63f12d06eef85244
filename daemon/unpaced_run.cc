#include "daemon/unpaced_run.h"

#include <stdexcept>

#include "daemon/sample_queue.h"
#include "hal/backend_factory.h"

namespace tribo::daemon {

UnpacedRun run_unpaced(const v1::DaemonConfig& config, const LoadFunction& load_function, std::uint64_t seed) {
  auto transducer = hal::make_transducer(config, seed);
  if (!transducer) throw std::runtime_error("cannot create the backend of this config");
  SpscQueue<Sample> queue(1 << 16);
  RunControl control;
  RunTelemetry telemetry;
  RunLoopConfig loop_config = run_loop_config_from(config);
  loop_config.backpressure = true;
  loop_config.time_stages_every = 0;  // unpaced: no clock reads (nobody asks for stage times)
  RunLoop loop(*transducer, load_function, loop_config, queue, control, telemetry);
  UnpacedRun run;
  run.samples.reserve(load_function.expected_samples() + 1024);
  Sample sample;
  while (loop.tick()) {
    while (queue.try_pop(sample)) run.samples.push_back(sample);
  }
  while (queue.try_pop(sample)) run.samples.push_back(sample);
  run.outcome = loop.outcome();
  return run;
}

}  // namespace tribo::daemon
