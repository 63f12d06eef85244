#include "daemon/loop_scheduling.h"

#include <pthread.h>
#include <sched.h>

#include <cstring>

namespace tribo::daemon {

LoopScheduling apply_loop_scheduling(int priority, bool paced) {
  if (priority <= 0) return {false, "normal scheduling (controller.loop_realtime_priority is 0)"};
  if (!paced) return {false, "normal scheduling (unpaced simulated runs do not ask for real time)"};
  sched_param param{};
  param.sched_priority = priority;
  if (const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0) {
    return {false, "normal scheduling: SCHED_FIFO priority " + std::to_string(priority) +
                       " refused (" + std::strerror(err) +
                       "; needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least the priority)"};
  }
  return {true, "SCHED_FIFO priority " + std::to_string(priority)};
}

}  // namespace tribo::daemon
