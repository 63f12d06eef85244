// The supervisor's per-tick stiffness check (drive_stiffness) against the
// full assessment it replaced (assess_drive): the same gap_closed and the
// same stiffness_ratio, bit for bit, so no trip decision moved (issue 17).
#include "daemon/electrostatic_drive.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>

namespace tribo::daemon {
namespace {

TEST(DriveStiffness, EqualsTheFullAssessmentBitForBit) {
  // The lateral axis of the default config (100 V bias) and the normal one (no bias).
  const ElectrostaticAxis axes[] = {{116, 1e-4, 120e-6, 126e-6, 100, 600},
                                    {100, 1e-4, 85e-6, 85e-6, 0, 600}};
  int closed = 0, below = 0, checked = 0;
  for (const ElectrostaticAxis& axis : axes) {
    for (double force = -12e-3; force <= 12e-3; force += 0.37e-3) {
      for (double x = -140e-6; x <= 140e-6; x += 3.3e-6) {
        for (double support : {0.0, 5e4}) {
          const DriveAssessment full = assess_drive(axis, force, x, support);
          const DriveStiffness quick = drive_stiffness(axis, force, x, support);
          ASSERT_EQ(quick.gap_closed, full.gap_closed) << force << " N at " << x << " m";
          ASSERT_EQ(std::bit_cast<std::uint64_t>(quick.stiffness_ratio),
                    std::bit_cast<std::uint64_t>(full.stiffness_ratio))
              << force << " N at " << x << " m";
          closed += full.gap_closed;
          below += !full.gap_closed && full.stiffness_ratio < 0.2;
          ++checked;
        }
      }
    }
  }
  // The grid reaches both outcomes the supervisor acts on, not only the safe one.
  EXPECT_GT(closed, 0);
  EXPECT_GT(below, 0);
  EXPECT_GT(checked - closed - below, 0);
}

}  // namespace
}  // namespace tribo::daemon
