// The confusion check (analysis/effects/confusion.h): an accepted effect is
// told apart from a rival whose extension leaves a different change of the
// model force, and not from one whose extension leaves the same. On a
// synthetic record (three loads, four speeds both ways, holds) the "final
// model" is LuGre with a log-velocity strengthening (0.002 per e-fold, in
// units of mu: 2 % of the level per e-fold) that the record shows clearly,
// and the measured force is that model plus white noise of 2 µN.
// Rate-and-state friction's direct effect a ln(v) has the same form on the
// record as the strengthening, so it must take up nearly all of it; a tilt
// force N tan(theta) does not flip with direction and a load exponent scales
// the level with the load, so neither can.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "analysis/effects/confusion.h"
#include "analysis/input/measured_series.h"
#include "analysis/motion/motion_segmentation.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

struct Record {
  MeasuredSeries series;
  MotionSegmentation motion;
  Record() : series(testing::synthetic_run({}, 1)) {
    derive_motion(series, 0);
    motion = segment_motion(series);
  }
};

struct Case {
  FitResult final_fit;
  std::vector<double> final_model;
  VisibleRows rows;
};

// The final model with velocity strengthening at `coeff` per e-fold (in
// units of mu), and the record's force set to it plus white noise.
Case strengthened(const ModelData& data, MeasuredSeries& series, double coeff, double noise_n) {
  ModelStructure st;
  st.load_scaled = true;
  ModelParams base = base_params(data, st);
  base.set_value("mu_c", 0.1);
  base.set_value("mu_s", 0.14);
  base.set_value("sigma0", 3000);
  base.set_value("Fv", 0.5);
  Case c;
  c.final_fit.params = with_effect(base, Effect::kVelocityStrengthening, data);
  c.final_fit.params.set_value("log_velocity_coeff", coeff);
  c.final_model = simulate(data, c.final_fit.params);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, noise_n);
  for (std::size_t i = 0; i < series.size(); ++i) series.force_n[i] = c.final_model[i] + noise(rng);
  std::vector<char> in_fit(series.size(), 1);
  std::vector<char> held(data.motion.heldout.begin(), data.motion.heldout.end());
  for (std::size_t i = 0; i < series.size(); ++i) in_fit[i] = !held[i];
  c.rows = visible_rows(data, c.final_fit, c.final_model, in_fit, held);
  return c;
}

const RivalConfusion& rival(const EffectConfusion& c, Effect e) {
  for (const RivalConfusion& r : c.rivals) {
    if (r.rival == e) return r;
  }
  throw std::runtime_error("rival not examined");
}

TEST(Confusion, ARivalOfTheSameFormIsNotDistinguishableAndOthersAre) {
  Record rec;
  const ModelData data(rec.series, rec.motion);
  const Case c = strengthened(data, rec.series, 0.002, 2e-6);
  const EffectConfusion conf =
      confusion_with_rivals(data, c.final_fit, c.final_model, c.rows, Effect::kVelocityStrengthening,
                            {Effect::kTiltOffset, Effect::kRateState, Effect::kLoadDependence, Effect::kDirectionAsymmetry});
  // The strengthening alone stands far clear of the strength gate here, so
  // whatever a rival leaves of it is measured, not lost in the noise.
  for (const auto& r : conf.rivals) {
    std::printf("[confusion] rival %s: z %.3g, explained %.4f (alone %.3g)\n", std::string(effect_name(r.rival)).c_str(), r.z,
                r.explained, conf.z_alone);
  }
  ASSERT_GT(conf.z_alone, 30.0);
  ASSERT_EQ(conf.rivals.size(), 4u);
  EXPECT_EQ(conf.rivals.front().rival, Effect::kRateState) << "nearest rival";
  EXPECT_FALSE(conf.distinguishable());
  const RivalConfusion& same = rival(conf, Effect::kRateState);
  EXPECT_LT(same.z, 1.0);
  EXPECT_GT(same.explained, 0.99);
  for (Effect other : {Effect::kTiltOffset, Effect::kLoadDependence}) {
    const RivalConfusion& r = rival(conf, other);
    EXPECT_GT(r.z, 0.7 * conf.z_alone) << effect_name(other);
    EXPECT_LT(r.explained, 0.5) << effect_name(other);
  }
  for (std::size_t k = 1; k < conf.rivals.size(); ++k) EXPECT_LE(conf.rivals[k - 1].z, conf.rivals[k].z);
}

TEST(Confusion, WithoutTheSameFormTheEffectIsDistinguishable) {
  Record rec;
  const ModelData data(rec.series, rec.motion);
  const Case c = strengthened(data, rec.series, 0.002, 2e-6);
  const EffectConfusion conf = confusion_with_rivals(data, c.final_fit, c.final_model, c.rows,
                                                     Effect::kVelocityStrengthening,
                                                     {Effect::kTiltOffset, Effect::kLoadDependence});
  EXPECT_TRUE(conf.distinguishable()) << effect_name(conf.rivals.front().rival) << " z " << conf.rivals.front().z;
  EXPECT_GT(conf.rivals.front().z, 0.7 * conf.z_alone);
}

// z is in the strength gate's units: ten times the noise, a tenth of the z.
TEST(Confusion, TheStatisticScalesAsStrengthOverNoise) {
  Record rec;
  const ModelData data(rec.series, rec.motion);
  const Case quiet = strengthened(data, rec.series, 0.01, 0.2e-6);
  const double z_quiet = confusion_with_rivals(data, quiet.final_fit, quiet.final_model, quiet.rows,
                                               Effect::kVelocityStrengthening, {Effect::kTiltOffset})
                             .rivals.front()
                             .z;
  const Case noisy = strengthened(data, rec.series, 0.01, 2e-6);
  const double z_noisy = confusion_with_rivals(data, noisy.final_fit, noisy.final_model, noisy.rows,
                                               Effect::kVelocityStrengthening, {Effect::kTiltOffset})
                             .rivals.front()
                             .z;
  EXPECT_NEAR(z_noisy / z_quiet, 0.1, 0.02);
}

}  // namespace
}  // namespace tribo::analysis
