// The loop thread's scheduling (an emergency stop acts within one
// loop period). At normal priority a woken loop waits for a core behind
// whatever else the machine runs (measured: maxima of 0.7-1 ms on a loaded
// 2-core machine against a 100 µs period); SCHED_FIFO lets it preempt them,
// as LinuxCNC's servo thread does.
#pragma once

#include <optional>
#include <string>

namespace tribo::daemon {

struct LoopScheduling {
  bool realtime = false;     // SCHED_FIFO in force on the loop thread
  std::string description;   // what is in force, or why real time was refused
};

// Called on the loop thread. priority 0 keeps normal scheduling; 1-99 asks
// for SCHED_FIFO at that priority. `paced` is false for a simulated run in
// lock-step (it would hold a core at real-time priority for nothing). A
// paced loop given a cpu is also pinned to it: with the bench emulator's
// server on the same core, a tick's two round trips over loopback need no
// wake-up of the other core (docs/modbus.md, "Loop rate over Modbus TCP");
// refused (no such CPU), the loop runs unpinned and the description says so.
LoopScheduling apply_loop_scheduling(int priority, bool paced, std::optional<int> cpu = std::nullopt);

}  // namespace tribo::daemon
