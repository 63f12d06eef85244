// Diagnosis on synthetic runs with one effect switched on and not declared.
//
// Synthetic: the
// forward model is tests/analysis/synthetic_run.h, written apart from the
// analysis's own candidate models (its own integrator and effect forms).
// tests/analysis/diagnosis_sim_test.cc runs the same checks on tribo's
// simulated instrument, where the lag and the sample's creep lie below what
// its protocol reveals (docs/identification.md, "Tests on tribo's simulated
// instrument and on synthetic runs").
#include <algorithm>
#include <cmath>
#include <optional>

#include <gtest/gtest.h>

#include "tests/analysis/analysis_test_support.h"
#include "tests/analysis/synthetic_run.h"

namespace tribo::analysis {
namespace {

using testing::accepted;
using testing::accepted_names;

Diagnosis diagnose_synthetic(const testing::SyntheticEffects& effects, std::uint64_t seed = 1,
                             std::vector<Effect> candidates = {kAllEffects.begin(), kAllEffects.end()}) {
  MeasuredSeries s = testing::synthetic_run(effects, seed);
  derive_motion(s, 0);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.candidates = std::move(candidates);
  return diagnose(s, options);
}

struct Case {
  const char* name;
  Effect effect;
  testing::SyntheticEffects truth;
  std::optional<Effect> mimic;  // the effect it could be mistaken for
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

std::vector<Case> cases() {
  auto with = [](auto set) {
    testing::SyntheticEffects e;
    set(e);
    return e;
  };
  return {
      {"dwell_stiction", Effect::kDwellStiction, with([](auto& e) { e.dwell_gain = 0.3; }), Effect::kDrift},
      {"frictional_lag", Effect::kFrictionalLag, with([](auto& e) { e.lag_time_s = 0.05; }), Effect::kPreslidingHysteresis},
      {"velocity_strengthening", Effect::kVelocityStrengthening, with([](auto& e) { e.log_velocity = 0.05; }), std::nullopt},
      {"load_dependence", Effect::kLoadDependence, with([](auto& e) { e.load_exponent = -1.0 / 3; }), Effect::kTiltOffset},
      {"position_periodic", Effect::kPositionPeriodic, with([](auto& e) { e.periodic_amplitude = 0.1; }), std::nullopt},
      {"direction_asymmetry", Effect::kDirectionAsymmetry, with([](auto& e) { e.asymmetry = 0.1; }), Effect::kTiltOffset},
      {"tilt_offset", Effect::kTiltOffset, with([](auto& e) { e.tilt_tan = 0.026; }), Effect::kDirectionAsymmetry},
      {"drift", Effect::kDrift, with([](auto& e) { e.drift_n_per_s = 0.2e-6; }), Effect::kDwellStiction},
      {"presliding_hysteresis", Effect::kPreslidingHysteresis, with([](auto& e) { e.breakaway_ratio = 0.5; }), Effect::kFrictionalLag},
      {"backlash", Effect::kBacklash, with([](auto& e) { e.backlash_gap_m = 0.3e-6; }), Effect::kPreslidingHysteresis},
  };
}

class UndeclaredEffect : public ::testing::TestWithParam<Case> {};

TEST_P(UndeclaredEffect, IsNamedFirstAndLowersTheHeldOutError) {
  const Case& c = GetParam();
  const Diagnosis d = diagnose_synthetic(c.truth);
  ASSERT_FALSE(d.accepted.empty()) << c.name << ": nothing accepted";
  EXPECT_EQ(d.accepted.front().effect, c.effect) << "accepted: " << accepted_names(d);
  if (c.mimic) {
    EXPECT_FALSE(accepted(d, *c.mimic)) << "mimic accepted: " << accepted_names(d);
  }
  EXPECT_LT(d.after.heldout.rms, 0.97 * d.before.heldout.rms);
  EXPECT_LT(d.after.fit.rms, d.before.fit.rms);
  // The accepted effect's parameters come with uncertainties.
  for (const auto& p : d.accepted.front().parameters) {
    if (p.fixed) continue;
    EXPECT_TRUE(std::isfinite(p.std_error)) << p.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Synthetic, UndeclaredEffect, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(DiagnosisSynthetic, ACleanRunAcceptsNothingAndLeavesNoStructure) {
  const Diagnosis d = diagnose_synthetic({});
  EXPECT_TRUE(d.accepted.empty()) << accepted_names(d);
  EXPECT_FALSE(d.unexplained) << *d.unexplained;
  EXPECT_EQ(d.rejected.size(), kAllEffects.size());
  for (const auto& r : d.rejected) EXPECT_FALSE(r.reason.empty()) << effect_name(r.effect);
}

TEST(DiagnosisSynthetic, StrongViscousFrictionIsNotMistakenForLogVelocity) {
  // The base model is viscous: a large Fv v must stay in the base, while a
  // log-velocity law over the same speeds is named (UndeclaredEffect above).
  testing::SyntheticEffects e;
  e.extra_viscous_n_s_per_m = 2.0;  // 64 µN more at 32 µm/s
  const Diagnosis d = diagnose_synthetic(e);
  EXPECT_FALSE(accepted(d, Effect::kVelocityStrengthening)) << accepted_names(d);
  EXPECT_NEAR(d.final_fit.params.value("Fv"), 2.5, 0.25);
}

TEST(DiagnosisSynthetic, TheNoiseFloorOfAQuantisedForceIsNotBelowItsSteps) {
  // Table 3.2's 3 uN force resolution over 0.5 uN of noise, 500 Hz: most
  // second differences of the residual are exactly 0, and their robust
  // spread gives 5.8e-9 N. The floor cannot be below the quantisation's own
  // step / sqrt(12) = 0.87 uN.
  testing::SyntheticOptions o;
  o.force_noise_n = 0.5e-6;
  o.rate_hz = 500;
  MeasuredSeries s = testing::synthetic_run({}, 2, o);
  for (double& f : s.force_n) f = std::round(f / 3e-6) * 3e-6;
  derive_motion(s, 0);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.candidates = {Effect::kTiltOffset};
  const Diagnosis d = diagnose(s, options);
  EXPECT_GT(d.noise_floor, 0.99 * 3e-6 / std::sqrt(12.0)) << "white_noise_rms " << white_noise_rms([&] {
    std::vector<double> r(s.size());
    for (std::size_t i = 0; i < r.size(); ++i) r[i] = s.force_n[i] - d.model_after[i];
    return r;
  }());
  EXPECT_LT(d.noise_floor, 2e-6);
}

// The candidate fit's iteration cap is for screening: a candidate that
// passes at it is judged and ranked as converged. A cap of 2 stops drift far
// short of what it explains; its trial must report the converged model's
// held-out error, the one accepted, and it must still be named first among
// the additive terms that can take up part of a drift.
TEST(DiagnosisSynthetic, ACandidateIsJudgedAsConvergedNotAtTheIterationCap) {
  testing::SyntheticEffects e;
  e.drift_n_per_s = 0.2e-6;
  MeasuredSeries s = testing::synthetic_run(e, 3);
  derive_motion(s, 0);
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.candidate_fit = {2, 1e-6};
  options.candidates = {Effect::kDrift, Effect::kDirectionAsymmetry, Effect::kTiltOffset};
  options.minimum_detectable = false;
  const Diagnosis d = diagnose(s, options);
  ASSERT_FALSE(d.accepted.empty());
  EXPECT_EQ(d.accepted.front().effect, Effect::kDrift) << accepted_names(d);
  ASSERT_EQ(d.accepted.size(), 1u) << accepted_names(d);
  EXPECT_NEAR(d.accepted.front().trial.heldout_rms_after, d.after.heldout.rms, 1e-9 * d.after.heldout.rms);
}

TEST(DiagnosisSynthetic, IsDeterministic) {
  testing::SyntheticEffects e;
  e.tilt_tan = 0.026;
  const std::vector<Effect> two = {Effect::kTiltOffset, Effect::kDirectionAsymmetry};
  const Diagnosis a = diagnose_synthetic(e, 4, two), b = diagnose_synthetic(e, 4, two);
  ASSERT_EQ(a.accepted.size(), 1u);
  ASSERT_EQ(a.model_after.size(), b.model_after.size());
  for (std::size_t i = 0; i < a.model_after.size(); ++i) ASSERT_EQ(a.model_after[i], b.model_after[i]);
}

// Each effect the confusion check refuses sends the record back to be
// diagnosed without it, the refused effects kept as rivals of the rest. A
// confusion z no rival can leave refuses every effect that has one: on a
// tilted tip's record with direction asymmetry as the other candidate (in
// sliding both add the same offset), the one accepted first is refused, then
// the other, and the final diagnosis names nothing and lists the refusals
// after its own rejections, the last refused first.
// A tilted tip's record (tan 0.026, seed 1), for the refusal tests.
MeasuredSeries tilted_record() {
  testing::SyntheticEffects tilted;
  tilted.tilt_tan = 0.026;
  MeasuredSeries s = testing::synthetic_run(tilted, 1);
  derive_motion(s, 0);
  return s;
}

TEST(DiagnosisSynthetic, EffectsRefusedInTurnAreEachDiagnosedAwayAndListedLastFirst) {
  const MeasuredSeries s = tilted_record();
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.candidates = {Effect::kTiltOffset, Effect::kDirectionAsymmetry};
  const Diagnosis kept = diagnose(s, options);
  ASSERT_FALSE(kept.accepted.empty());
  const Effect first = kept.accepted.front().effect;
  const Effect second = first == Effect::kTiltOffset ? Effect::kDirectionAsymmetry : Effect::kTiltOffset;

  options.min_confusion_z = 1e9;
  const Diagnosis refused = diagnose(s, options);
  EXPECT_TRUE(refused.accepted.empty()) << "accepted: " << accepted_names(refused);
  ASSERT_GE(refused.rejected.size(), 2u);
  const RejectedEffect& last = refused.rejected.back();
  const RejectedEffect& before_last = refused.rejected[refused.rejected.size() - 2];
  EXPECT_EQ(effect_name(last.effect), effect_name(first)) << last.reason;
  EXPECT_EQ(effect_name(before_last.effect), effect_name(second)) << before_last.reason;
  for (const RejectedEffect* r : {&last, &before_last}) {
    EXPECT_NE(r->reason.find("diagnosed again without it"), std::string::npos) << r->reason;
  }
  for (Effect e : {first, second}) {
    EXPECT_EQ(std::count_if(refused.rejected.begin(), refused.rejected.end(),
                            [e](const RejectedEffect& r) { return r.effect == e; }),
              1)
        << effect_name(e) << " listed more than once";
  }
}

// On a tilted tip's record with tilt, direction asymmetry and drift as
// candidates and a confusion z no rival leaves, each accepted effect is
// refused in turn: every rediagnosis is taken up from a round, and the final
// diagnosis is the one diagnosing from the base fit each time gives, bit for
// bit (analysis/round_log.h).
TEST(DiagnosisSynthetic, ARediagnosisTakenUpAtTheRefusedRoundIsTheOneWithoutTheEffect) {
  const MeasuredSeries s = tilted_record();
  DiagnosisOptions options;
  options.base.load_scaled = true;
  options.candidates = {Effect::kTiltOffset, Effect::kDirectionAsymmetry, Effect::kDrift};
  options.min_confusion_z = 1e9;
  options.minimum_detectable = false;
  const Diagnosis resumed = diagnose(s, options);
  options.resume_at_refused_round = false;
  const Diagnosis from_base = diagnose(s, options);

  ASSERT_GE(resumed.rejected.size(), 2u);
  EXPECT_NE(resumed.rejected.back().reason.find("diagnosed again without it"), std::string::npos);
  ASSERT_EQ(resumed.trials.size(), from_base.trials.size());
  for (std::size_t k = 0; k < resumed.trials.size(); ++k) {
    EXPECT_EQ(resumed.trials[k].effect, from_base.trials[k].effect) << k;
    EXPECT_EQ(resumed.trials[k].round, from_base.trials[k].round) << k;
    EXPECT_EQ(resumed.trials[k].heldout_gain, from_base.trials[k].heldout_gain) << k;
  }
  EXPECT_EQ(accepted_names(resumed), accepted_names(from_base));
  ASSERT_EQ(resumed.rejected.size(), from_base.rejected.size());
  for (std::size_t k = 0; k < resumed.rejected.size(); ++k) {
    EXPECT_EQ(resumed.rejected[k].effect, from_base.rejected[k].effect) << k;
    EXPECT_EQ(resumed.rejected[k].reason, from_base.rejected[k].reason) << k;
  }
  EXPECT_EQ(resumed.final_fit.rss, from_base.final_fit.rss);
  EXPECT_EQ(resumed.model_after, from_base.model_after);
}

}  // namespace
}  // namespace tribo::analysis
