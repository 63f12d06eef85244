#include "daemon/loop_scheduling.h"

#include <pthread.h>
#include <sched.h>

#include <cstring>

namespace tribo::daemon {

namespace {

// "; on CPU n", or why not.
std::string pin_to_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (cpu < 0 || cpu >= CPU_SETSIZE) return "; CPU " + std::to_string(cpu) + " refused (no such CPU)";
  CPU_SET(cpu, &set);
  if (const int err = pthread_setaffinity_np(pthread_self(), sizeof set, &set); err != 0) {
    return "; CPU " + std::to_string(cpu) + " refused (" + std::strerror(err) + "), not pinned";
  }
  return "; on CPU " + std::to_string(cpu);
}

LoopScheduling priority_of(int priority) {
  if (priority <= 0) return {false, "normal scheduling (controller.loop_realtime_priority is 0)"};
  sched_param param{};
  param.sched_priority = priority;
  if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
    return {false, "normal scheduling: SCHED_FIFO priority " + std::to_string(priority) +
                       " refused (" + std::strerror(err) +
                       "; needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least the priority)"};
  }
  return {true, "SCHED_FIFO priority " + std::to_string(priority)};
}

}  // namespace

LoopScheduling apply_loop_scheduling(int priority, bool paced, std::optional<int> cpu) {
  if (!paced) return {false, "normal scheduling (unpaced simulated runs do not ask for real time)"};
  LoopScheduling s = priority_of(priority);
  if (cpu) s.description += pin_to_cpu(*cpu);
  return s;
}

}  // namespace tribo::daemon
