#include "daemon/acquisition.h"

namespace tribo::daemon {

bool Acquisition::add(const Sample& tick, std::uint32_t ticks_per_sample, Sample& out) {
  if (count_ == 0) {
    sum_ = tick;
  } else {
    sum_.time_s += tick.time_s;
    sum_.normal_setpoint_n += tick.normal_setpoint_n;
    sum_.normal_force_n += tick.normal_force_n;
    sum_.normal_displacement_m += tick.normal_displacement_m;
    sum_.lateral_setpoint_m += tick.lateral_setpoint_m;
    sum_.lateral_position_m += tick.lateral_position_m;
    sum_.lateral_force_n += tick.lateral_force_n;
    sum_.status_flags |= tick.status_flags;
  }
  if (++count_ < ticks_per_sample) return false;
  const double n = count_;
  out = Sample{sum_.time_s / n,
               sum_.segment_index,
               sum_.normal_setpoint_n / n,
               sum_.normal_force_n / n,
               sum_.normal_displacement_m / n,
               sum_.lateral_setpoint_m / n,
               sum_.lateral_position_m / n,
               sum_.lateral_force_n / n,
               sum_.status_flags};
  count_ = 0;
  return true;
}

}  // namespace tribo::daemon
