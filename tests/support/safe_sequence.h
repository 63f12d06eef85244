// The safe stop sequence (daemon/stop_sequence.h) as it shows in recorded
// samples, for every test that provokes a trip or an abort, whichever backend
// ran it: the daemon tests on the simulated instrument and the Modbus tests
// against tribo-bench.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "proto/sample_record.h"
#include "tribo/v1/api.pb.h"
#include "tribo/v1/daemon_config.pb.h"

namespace tribo::testing {

inline int first_sample_with(const v1::SampleBlock& b, std::uint32_t flag) {
  for (int i = 0; i < sample_count(b); ++i) {
    if (b.status_flags(i) & flag) return i;
  }
  return -1;
}

// The safe stop sequence in the recorded samples: from the first flagged
// sample on, every sample is flagged; the normal setpoint only falls, at no
// more than the unload rate, to 0; the lateral setpoint is held while the
// load comes off, then only moves towards 0, at no more than the retract
// speed, and ends at 0. lateral_held: false when the lateral position was
// unusable (the axis then holds and ramps its drive instead).
inline void expect_safe_sequence(const v1::SampleBlock& b, const v1::DaemonConfig& config,
                                 bool lateral_held = true) {
  const int first = first_sample_with(b, v1::SAFE_UNLOAD);
  ASSERT_GE(first, 0) << "no safe stop sequence";
  const int n = sample_count(b);
  const double dt = b.time_s(1) - b.time_s(0);
  const double unload_step = config.supervisor().unload_rate_n_per_s() * dt;
  const double retract_step = config.supervisor().retract_speed_m_per_s() * dt;
  // The first flagged sample also averages ticks from before the stop.
  const int from = first + 1;
  ASSERT_LT(from + 2, n);
  const double held = b.lateral_setpoint_m(from);
  bool retracting = false;
  for (int i = from; i < n; ++i) {
    ASSERT_TRUE(b.status_flags(i) & v1::SAFE_UNLOAD) << i;
    EXPECT_LE(b.normal_setpoint_n(i), b.normal_setpoint_n(i - 1) + 1e-15) << "normal rises at " << i;
    EXPECT_GE(b.normal_setpoint_n(i), b.normal_setpoint_n(i - 1) - unload_step * 1.000001 - 1e-15)
        << "normal unloads faster than the unload rate at " << i;
    if (!lateral_held) continue;
    const double x = b.lateral_setpoint_m(i), previous = b.lateral_setpoint_m(i - 1);
    if (!retracting && x != held) {
      retracting = true;
      EXPECT_EQ(b.normal_setpoint_n(i - 1), 0.0) << "lateral moved before the load was off, at " << i;
    }
    if (retracting && i > from) {
      EXPECT_LE(std::fabs(x), std::fabs(previous) + 1e-15) << "lateral moves away from 0 at " << i;
      EXPECT_LE(std::fabs(x - previous), retract_step * 1.000001 + 1e-15) << "retract too fast at " << i;
    }
  }
  EXPECT_EQ(b.normal_setpoint_n(n - 1), 0.0) << "not unloaded";
  if (lateral_held) {
    EXPECT_EQ(b.lateral_setpoint_m(n - 1), 0.0) << "not retracted";
    EXPECT_NEAR(b.lateral_position_m(n - 1), 0.0, 0.3e-6) << "the tip is not back at the neutral point";
  }
}

}  // namespace tribo::testing
