// The drift spline's knot count, chosen by leaving each fitted pass out
// (analysis/effects/drift_knot_choice.h): a straight drift takes the fewest
// intervals, a drift that wanders within the record takes more.
#include "analysis/effects/drift_knot_choice.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/motion/motion_segmentation.h"
#include "sim/noise_source.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

struct Record {
  Record() : series(make()), motion(segment_motion(series)), data(series, motion) {}
  static MeasuredSeries make() {
    MeasuredSeries s = testing::synthetic_run({}, 5);
    derive_motion(s, 0);
    return s;
  }
  std::vector<char> in_fit() const {
    std::vector<char> mask(series.size());
    for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = !motion.heldout[i];
    return mask;
  }
  // A residual of drift(t) plus 1 uN of white noise (a fixed stream).
  template <class Drift>
  std::vector<double> residual(Drift drift) const {
    sim::NoiseSource noise(11);
    std::vector<double> r(series.size());
    for (std::size_t i = 0; i < r.size(); ++i) r[i] = drift(series.time_s[i]) + 1e-6 * noise.gaussian();
    return r;
  }
  MeasuredSeries series;
  MotionSegmentation motion;
  ModelData data;
};

double cv_rms_at(const DriftKnotChoice& c, int intervals) {
  for (const auto& [k, rms] : c.cv_rms) {
    if (k == intervals) return rms;
  }
  return NAN;
}

TEST(DriftKnotChoice, AStraightDriftTakesTheFewestIntervals) {
  Record r;
  ASSERT_GT(r.data.drift_intervals(), 4) << "the record must leave a choice";
  const double t0 = r.series.time_s.front(), t1 = r.series.time_s.back();
  const DriftKnotChoice c =
      choose_drift_intervals(r.data, r.residual([&](double t) { return 20e-6 * (t - t0) / (t1 - t0); }), r.in_fit());
  EXPECT_EQ(c.intervals, 3);
  EXPECT_EQ(r.data.drift_intervals(), 3);  // left set
  EXPECT_EQ(static_cast<int>(c.cv_rms.size()), c.default_intervals - 2);
}

TEST(DriftKnotChoice, AWanderingDriftTakesMoreAndIsPredictedBetterForIt) {
  Record r;
  const double t0 = r.series.time_s.front(), t1 = r.series.time_s.back();
  // Two and a half periods over the record, 10 uN: three intervals cannot follow it.
  const auto wander = [&](double t) { return 10e-6 * std::sin(2 * std::numbers::pi * 2.5 * (t - t0) / (t1 - t0)); };
  const DriftKnotChoice c = choose_drift_intervals(r.data, r.residual(wander), r.in_fit());
  EXPECT_GT(c.intervals, 3);
  EXPECT_EQ(r.data.drift_functions, c.intervals + 3);
  EXPECT_LT(cv_rms_at(c, c.intervals), 0.5 * cv_rms_at(c, 3));
}

}  // namespace
}  // namespace tribo::analysis
