// The safe stop sequence as an activity of its own: an emergency stop that
// arrives while nothing runs unloads the instrument from the drive it holds
// now (hal/last_drive_transducer.h), as a faulted run's stop sequence would.
//
// A protocol need not end unloaded, so a SUCCESS run may leave the tip
// loaded (its last segment's drive stays on the backend). No position
// setpoint survives the run, so the lateral axis is held and retracted by
// its drive (daemon/stop_sequence.h, open loop): the normal drive ramps to
// 0 at unload_rate_n_per_s, then the lateral drive to 0 at the spring rate.
// Each drive passes the supervisor's command check before it is written.
#pragma once

#include <atomic>
#include <cstdint>

#include "daemon/run_loop.h"
#include "hal/transducer.h"

namespace tribo::daemon {

struct IdleStopOutcome {
  std::uint64_t ticks = 0;
  bool command_refused = false;  // a drive failed the check: writing stopped there
  std::uint64_t failed_writes = 0;
};

// Runs the sequence from `from` to its end on this thread (the loop's).
// acted_ns, if given, receives the monotonic time of the first drive written.
IdleStopOutcome run_idle_stop(hal::Transducer& transducer, const RunLoopConfig& config,
                              const hal::DriveCommand& from, std::atomic<std::int64_t>* acted_ns);

}  // namespace tribo::daemon
