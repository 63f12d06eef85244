// Whether the final model describes the record (analysis/models/model_adequacy.h):
// a model past a physical bound names no effect. A negative viscous
// coefficient counts once its 95 % interval lies below zero, however small
// its force at the record's speeds (the base bounds alone let -0.5 N s/m
// through on a record sliding at micrometres per second).
#include <gtest/gtest.h>

#include "analysis/models/model_adequacy.h"
#include "analysis/input/measured_series.h"
#include "analysis/motion/motion_segmentation.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

struct Fixture {
  MeasuredSeries series;
  MotionSegmentation motion;
  Fixture() : series(testing::synthetic_run({}, 1)) {
    derive_motion(series, 0);
    motion = segment_motion(series);
  }
};

FitResult base_fit(const ModelData& data, double fv, double fv_se) {
  ModelStructure st;
  st.load_scaled = true;
  FitResult fit;
  fit.params = base_params(data, st);
  fit.params.set_value("mu_c", 0.1);
  fit.params.set_value("mu_s", 0.14);
  fit.params.set_value("sigma0", 3000);
  fit.params.set_value("Fv", fv);
  ParamEstimate e;
  e.name = "Fv";
  e.unit = "N s/m";
  e.value = fv;
  e.std_error = fv_se;
  fit.estimates.push_back(e);
  return fit;
}

TEST(ModelAdequacy, APhysicalModelDescribesTheRecord) {
  const Fixture f;
  const ModelData data(f.series, f.motion);
  const ModelAdequacy a = judge_model_adequacy(data, base_fit(data, 0.2, 0.05));
  EXPECT_TRUE(a.describes_record);
  EXPECT_TRUE(a.reasons.empty());
}

TEST(ModelAdequacy, AViscousCoefficientWithinItsErrorOfZeroIsNoObjection) {
  const Fixture f;
  const ModelData data(f.series, f.motion);
  EXPECT_TRUE(judge_model_adequacy(data, base_fit(data, -0.01, 0.02)).describes_record);
}

TEST(ModelAdequacy, ANegativeViscousCoefficientClearOfZeroDoesNotDescribeTheRecord) {
  const Fixture f;
  const ModelData data(f.series, f.motion);
  const ModelAdequacy a = judge_model_adequacy(data, base_fit(data, -0.5, 0.1));
  EXPECT_FALSE(a.describes_record);
  ASSERT_EQ(a.reasons.size(), 1u);
  EXPECT_NE(a.reasons[0].find("negative viscous friction"), std::string::npos) << a.reasons[0];
}

TEST(ModelAdequacy, AStaticCoefficientPastItsBoundDoesNotDescribeTheRecord) {
  const Fixture f;
  const ModelData data(f.series, f.motion);
  FitResult fit = base_fit(data, 0.2, 0.05);
  fit.params.set_value("mu_s", 1.9e16);
  const ModelAdequacy a = judge_model_adequacy(data, fit);
  EXPECT_FALSE(a.describes_record);
  std::string all;
  for (const auto& r : a.reasons) all += r + "\n";
  EXPECT_NE(all.find("friction coefficients above 2"), std::string::npos) << all;
}

}  // namespace
}  // namespace tribo::analysis
