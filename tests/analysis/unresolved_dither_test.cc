// The unresolved-dither term of the base model (ModelStructure::
// unresolved_dither, DitherTerm::choose) on records whose tip jitters faster
// than the record samples it. The records come from a generator of their own:
// a LuGre contact stepped at 10 kHz, each tick at the commanded speed plus
// the velocity of a position jitter of a few tens of picometres (what a loop
// that feeds its sensor noise back does), sampled at 500 Hz with the
// position's noise and quantisation; the contact sees the dither in its
// Stribeck level too, which the model's term leaves at the resolved speed.
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/input/measured_series.h"
#include "analysis/models/lugre_fit.h"

namespace tribo::analysis {
namespace {

constexpr double kTickS = 1e-4, kSampleS = 2e-3;
constexpr double kMuC = 0.10, kMuS = 0.13, kVs = 4e-6, kSigma0 = 5000, kSigma1 = 5, kFv = 0.4, kNormalN = 1e-3;

// Reciprocating passes of 5 µm at 0.3, 1, 3 and 10 µm/s, both ways, twice,
// each after a hold of 1 s; dither: the RMS of the tick velocity's jitter.
MeasuredSeries dithered_record(double dither_m_per_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  const double jitter_m = dither_m_per_s * kTickS / std::numbers::sqrt2;  // position jitter whose differences have that RMS
  MeasuredSeries s;
  s.force_unit = "N";
  double x = 0, z = 0, t = 0, jitter = 0;
  const int ticks_per_sample = static_cast<int>(std::lround(kSampleS / kTickS));
  int tick = 0;
  std::vector<double> commanded;
  auto run = [&](double speed, double duration_s) {
    const auto ticks = static_cast<long>(std::lround(duration_s / kTickS));
    for (long k = 0; k < ticks; ++k) {
      const double next_jitter = jitter_m * unit(rng);
      const double v = speed + (next_jitter - jitter) / kTickS;
      jitter = next_jitter;
      const double level = kNormalN * (kMuC + (kMuS - kMuC) * std::exp(-std::fabs(v) / kVs));
      const double a = std::fabs(v) * kSigma0 / level;
      const double z_next = a * kTickS < 1e-12 ? z + v * kTickS : z * std::exp(-a * kTickS) + v * (1 - std::exp(-a * kTickS)) / a;
      const double dz_dt = (z_next - z) / kTickS;
      z = z_next;
      x += speed * kTickS;
      t += kTickS;
      if (++tick % ticks_per_sample != 0) continue;
      const double position = x + jitter + 10e-9 * unit(rng);
      s.time_s.push_back(t);
      s.position_m.push_back(4e-9 * std::round(position / 4e-9));
      s.force_n.push_back(kSigma0 * z + kSigma1 * dz_dt + kFv * v + 2e-6 * unit(rng));
      s.normal_force_n.push_back(kNormalN);
      commanded.push_back(speed);
    }
  };
  for (int cycle = 0; cycle < 2; ++cycle) {
    for (double speed : {0.3e-6, 1e-6, 3e-6, 10e-6}) {
      for (double direction : {1.0, -1.0}) {
        run(0.0, 1.0);
        run(direction * speed, 5e-6 / speed);
      }
    }
  }
  // The motion as resolved: the commanded velocity, which a loop that
  // follows its setpoint gives once the dither is averaged out. The
  // position noise floor is the record's, estimated as for any record.
  derive_motion(s, 0);
  s.velocity_m_per_s = commanded;
  s.velocity_measured = true;
  s.acceleration_m_per_s2.assign(s.size(), 0.0);
  return s;
}

Diagnosis diagnose_base_with_dither_choice(const MeasuredSeries& s) {
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.base.stribeck_exponent = 1.0;
  options.candidates = {};
  options.minimum_detectable = false;
  options.dither = DitherTerm::choose;
  return diagnose(s, options);
}

// A tip dithering at 0.5 µm/s RMS (a tenth of the Stribeck velocity, as a
// soft I-PD loop at Table 3.2's floors gives): the dither drains the bristle
// in every hold and at every reversal. The base with the dither predicts
// the held-out data better, is kept, and reads the dither and the contact
// stiffness near their truth. (Four speeds do not fix the Stribeck curve
// apart from the viscous term, so the levels are not checked.)
TEST(UnresolvedDither, IsKeptWhereTheTipDithersAndReadsItsSpeed) {
  const MeasuredSeries s = dithered_record(0.5e-6, 3);
  const Diagnosis d = diagnose_base_with_dither_choice(s);
  ASSERT_TRUE(d.dither.has_value());
  const DitherChoice& c = *d.dither;
  EXPECT_TRUE(c.chosen) << "held-out RMS " << c.heldout_rms_without << " -> " << c.heldout_rms_with << ", "
                        << c.excess_se_without << " SE; " << c.objection;
  EXPECT_LT(c.heldout_rms_with, 0.9 * c.heldout_rms_without);
  EXPECT_NEAR(c.dither_speed_m_per_s, 0.5e-6, 0.15e-6);
  const ModelParams& p = d.base.result.params;
  ASSERT_GE(p.index("dither_speed"), 0);
  EXPECT_NEAR(p.value("sigma0"), kSigma0, 0.1 * kSigma0);
}

// The same record without the dither: the term brings nothing the held-out
// passes confirm, and the plain base is kept.
TEST(UnresolvedDither, IsLeftOutWhereTheTipDoesNotDither) {
  const MeasuredSeries s = dithered_record(0.0, 3);
  const Diagnosis d = diagnose_base_with_dither_choice(s);
  ASSERT_TRUE(d.dither.has_value());
  EXPECT_FALSE(d.dither->chosen) << "held-out RMS " << d.dither->heldout_rms_without << " -> " << d.dither->heldout_rms_with
                                 << ", " << d.dither->excess_se_without << " SE";
  EXPECT_LT(d.base.result.params.index("dither_speed"), 0);
}

// A dither whose position excursion at the Nyquist frequency would exceed
// the position noise is one the record would show: past a bound.
TEST(UnresolvedDither, ADitherTheRecordWouldResolveIsPastABound) {
  const MeasuredSeries s = dithered_record(0.0, 4);
  const MotionSegmentation motion = segment_motion(s);
  const ModelData data(s, motion);
  ModelStructure st;
  st.load_scaled = true;
  st.unresolved_dither = true;
  FitResult fit;
  fit.params = base_params(data, st);
  fit.params.set_value("mu_c", kMuC);
  fit.params.set_value("mu_s", kMuS);
  fit.params.set_value("Fv", kFv);
  const double resolved = std::numbers::pi * 500.0 * s.position_noise_m;
  ASSERT_GT(s.position_noise_m, 0.0);
  fit.params.set_value("dither_speed", 0.5 * resolved);
  EXPECT_TRUE(base_out_of_bounds(data, fit).empty());
  fit.params.set_value("dither_speed", 2 * resolved);
  const std::vector<std::string> objections = base_out_of_bounds(data, fit);
  ASSERT_EQ(objections.size(), 1u);
  EXPECT_NE(objections.front().find("a dither the record would resolve"), std::string::npos) << objections.front();
}

}  // namespace
}  // namespace tribo::analysis
