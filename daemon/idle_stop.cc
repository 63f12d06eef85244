#include "daemon/idle_stop.h"

#include <cmath>

#include "daemon/safety_supervisor.h"
#include "daemon/stop_sequence.h"
#include "daemon/tick_timing.h"

namespace tribo::daemon {

IdleStopOutcome run_idle_stop(hal::Transducer& transducer, const RunLoopConfig& config,
                              const hal::DriveCommand& from, std::atomic<std::int64_t>* acted_ns) {
  IdleStopOutcome outcome;
  SafetySupervisor supervisor(config.supervisor);
  StopSequence stop(config.stop);
  // NaN hold: both axes open loop, from the drives held now (no controller
  // state survives the last activity, so no closed loop could start bumpless).
  stop.begin(from, std::nan(""), 0, 1);
  hal::SensorFrame frame;
  while (!stop.done()) {
    // The reading only paces the settle phase; open loop needs no valid one.
    transducer.read(frame);
    const TickSetpoints sp = stop.next(frame);
    const hal::DriveCommand drive{sp.normal, sp.lateral};
    if (!supervisor.command_allowed(drive, sp.normal, sp.lateral, true, outcome.ticks)) {
      outcome.command_refused = true;  // the backend keeps the last drive written
      break;
    }
    if (transducer.write(drive) != hal::IoResult::kOk) ++outcome.failed_writes;
    if (outcome.ticks == 0 && acted_ns != nullptr) {
      acted_ns->store(static_cast<std::int64_t>(monotonic_ns()), std::memory_order_relaxed);
    }
    ++outcome.ticks;
    transducer.wait_next_tick();
  }
  return outcome;
}

}  // namespace tribo::daemon
