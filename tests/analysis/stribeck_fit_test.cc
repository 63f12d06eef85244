#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "analysis/models/stribeck_fit.h"

namespace tribo::analysis {
namespace {

// Table 6.2 of the dissertation, 5 N: mu = p1 + p2 exp(-p3 x) + p4 x against the Gumbel number.
constexpr double kP1 = 0.0159, kP2 = 0.0937, kP3 = 3.07e5, kP4 = 388.9;

std::vector<CurvePoint> eq44_points(unsigned seed, bool outliers) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::vector<CurvePoint> pts;
  for (int k = 0; k < 40; ++k) {
    const double x = 1e-7 * std::pow(10.0, 3.0 * k / 39.0);  // 1e-7 .. 1e-4
    pts.push_back({x, kP1 + kP2 * std::exp(-kP3 * x) + kP4 * x + noise(rng), 1.0});
  }
  if (outliers) {
    // The kind of end points the dissertation dropped by hand (§6.3.2).
    pts.front().y += 0.03;
    pts.back().y -= 0.02;
  }
  return pts;
}

TEST(StribeckFit, Eq44RecoversTable62WithoutAnInitialGuess) {
  const CurveFit fit = fit_eq44(eq44_points(1, false));
  EXPECT_NEAR(fit.value("p1"), kP1, 3 * fit.std_errors[0]);
  EXPECT_NEAR(fit.value("p2"), kP2, 3 * fit.std_errors[1]);
  EXPECT_NEAR(fit.value("p3"), kP3, 3 * fit.std_errors[2]);
  EXPECT_NEAR(fit.value("p4"), kP4, 3 * fit.std_errors[3]);
  EXPECT_LT(fit.std_errors[2], 0.1 * kP3);
  EXPECT_TRUE(fit.scale_determined);
}

TEST(StribeckFit, Eq44DownweightsEndOutliersInsteadOfDroppingThem) {
  const auto pts = eq44_points(2, true);
  const CurveFit fit = fit_eq44(pts);
  EXPECT_LT(fit.robust_weights.front(), 0.2);
  EXPECT_LT(fit.robust_weights.back(), 0.2);
  EXPECT_NEAR(fit.value("p3"), kP3, 0.1 * kP3);
  EXPECT_NEAR(fit.value("p1") + fit.value("p2"), kP1 + kP2, 0.003);
}

TEST(StribeckFit, LugreSteadyStateRecoversStribeckVelocityAndOffset) {
  // LuGre steady state (dissertation §2, eqs. 9-13) with its exponential shape.
  const double fc = 100e-6, fs = 143e-6, vs = 1.2e-6, fv = 0.5, offset = 3e-6;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5e-6);
  std::vector<CurvePoint> pts;
  for (int k = 0; k < 30; ++k) {
    const double speed = 0.1e-6 * std::pow(10.0, 3.0 * k / 29.0);
    for (double sign : {1.0, -1.0}) {
      const double f = sign * (fc + (fs - fc) * std::exp(-speed / vs)) + fv * sign * speed + offset;
      pts.push_back({sign * speed, f + noise(rng), 1.0});
    }
  }
  const CurveFit fit = fit_stribeck_curve(pts, 1.0, true);
  EXPECT_NEAR(fit.value("Fc"), fc, 1e-6);
  EXPECT_NEAR(fit.value("Fs"), fs, 2e-6);
  EXPECT_NEAR(fit.value("vs"), vs, 0.1e-6);
  EXPECT_NEAR(fit.value("Fv"), fv, 0.05);
  EXPECT_NEAR(fit.value("offset"), offset, 0.3e-6);
  EXPECT_NEAR(stribeck_curve(fit, 2e-6, 1.0), fc + (fs - fc) * std::exp(-2e-6 / vs) + fv * 2e-6 + offset, 1e-6);
}

TEST(StribeckFit, WarnsWhenTheStribeckScaleLiesOutsideTheData) {
  // Only fast sliding: the Stribeck drop is not sampled.
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.5e-6);
  std::vector<CurvePoint> pts;
  for (int k = 0; k < 20; ++k) {
    const double speed = 50e-6 + 5e-6 * k;
    pts.push_back({speed, 100e-6 + 0.5 * speed + noise(rng), 1.0});
    pts.push_back({-speed, -100e-6 - 0.5 * speed + noise(rng), 1.0});
  }
  const CurveFit fit = fit_stribeck_curve(pts, 1.0, false);
  EXPECT_FALSE(fit.scale_determined);
  ASSERT_FALSE(fit.warnings.empty());
  EXPECT_NE(fit.warnings[0].find("vs is not determined"), std::string::npos);
  EXPECT_NEAR(fit.value("Fv"), 0.5, 0.05);
}

}  // namespace
}  // namespace tribo::analysis
