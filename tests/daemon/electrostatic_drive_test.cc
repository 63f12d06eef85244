// The supervisor's per-tick stiffness check (drive_stiffness) against the
// full assessment it replaced (assess_drive): the same gap_closed and the
// same stiffness_ratio, bit for bit, so no trip decision moves.
#include "daemon/electrostatic_drive.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
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

// The supervisor clears most ticks with stiffness_certainly_above and asks
// drive_stiffness only when it is not certain: the certificate must never
// clear a drive that drive_stiffness would trip (gap closed or k_eff / k
// below the minimum), here on a grid and at the limit itself, found by
// bisection on the force, where the two sides differ by an ulp.
TEST(DriveStiffness, TheDivisionFreeCertificateNeverClearsATrip) {
  const ElectrostaticAxis axes[] = {{116, 1e-4, 120e-6, 126e-6, 100, 600},
                                    {100, 1e-4, 85e-6, 85e-6, 0, 600}};
  const auto trips = [](const ElectrostaticAxis& axis, double force, double x, double support, double min) {
    const DriveStiffness d = drive_stiffness(axis, force, x, support);
    return d.gap_closed || d.stiffness_ratio < min;
  };
  int cleared = 0, undecided = 0, at_limit = 0;
  for (const ElectrostaticAxis& axis : axes) {
    for (double min : {0.2, 0.5}) {
      for (double support : {0.0, 37.0, 5e4}) {
        for (double x = -140e-6; x <= 140e-6; x += 3.3e-6) {
          for (double force = -12e-3; force <= 12e-3; force += 0.37e-3) {
            const bool certain = stiffness_certainly_above(axis, force, x, support, min);
            ASSERT_FALSE(certain && trips(axis, force, x, support, min)) << force << " N at " << x << " m";
            cleared += certain;
            undecided += !certain && !trips(axis, force, x, support, min);
          }
          // The force at which the ratio crosses the minimum, to the last bit.
          for (double sign : {1.0, -1.0}) {
            double safe = 0, tripping = sign * 1.0;
            if (trips(axis, safe, x, support, min) || !trips(axis, tripping, x, support, min)) continue;
            for (int i = 0; i < 200; ++i) {
              const double mid = 0.5 * (safe + tripping);
              if (mid == safe || mid == tripping) break;
              (trips(axis, mid, x, support, min) ? tripping : safe) = mid;
            }
            ASSERT_TRUE(trips(axis, tripping, x, support, min));
            EXPECT_FALSE(stiffness_certainly_above(axis, tripping, x, support, min)) << tripping << " N at " << x;
            // Within the certificate's margin of the limit (not where the
            // active plate changes side at 0 N): not certain either.
            if (std::fabs(drive_stiffness(axis, safe, x, support).stiffness_ratio - min) < 1e-10) {
              EXPECT_FALSE(stiffness_certainly_above(axis, safe, x, support, min)) << safe << " N at " << x;
              ++at_limit;
            }
          }
        }
      }
    }
  }
  // It clears most of the grid (the point of it), and leaves the rest to the exact check.
  EXPECT_GT(cleared, 10 * undecided);
  EXPECT_GT(at_limit, 100);
  // Not finite: never certain.
  EXPECT_FALSE(stiffness_certainly_above(axes[0], std::nan(""), 0, 0, 0.2));
  EXPECT_FALSE(stiffness_certainly_above(axes[0], 1e-3, std::nan(""), 0, 0.2));
  EXPECT_FALSE(stiffness_certainly_above(axes[1], 1e-3, 0, std::nan(""), 0.2));
  EXPECT_FALSE(stiffness_certainly_above(axes[0], HUGE_VAL, 0, 0, 0.2));
}

}  // namespace
}  // namespace tribo::daemon
