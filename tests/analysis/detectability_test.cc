// The normal quantile behind the minimum detectable strength's 90 % margin
// (analysis/effects/detectability.h), against tabulated values.
#include "analysis/effects/detectability.h"

#include <gtest/gtest.h>

namespace tribo::analysis {
namespace {

TEST(Detectability, TheNormalQuantileIsTheTabulatedOne) {
  EXPECT_NEAR(normal_quantile(0.9), 1.2815515655446004, 1e-12);
  EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(normal_quantile(0.5), 0.0, 1e-12);
  EXPECT_NEAR(normal_quantile(0.1), -1.2815515655446004, 1e-12);
  EXPECT_NEAR(normal_quantile(1e-9), -5.997807015007686, 1e-9);
}

}  // namespace
}  // namespace tribo::analysis
