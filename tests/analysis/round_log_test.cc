// A diagnosis without a refused effect, taken up from the round that
// accepted it (analysis/round_log.h): the rounds' bookkeeping on a made-up
// log. On a synthetic record, the same diagnosis as from the base fit:
// tests/analysis/diagnosis_synthetic_test.cc.
#include <gtest/gtest.h>

#include <string>

#include "analysis/round_log.h"

namespace tribo::analysis {
namespace {

CandidateTrial trial(Effect e, int round, bool passed, double gain) {
  CandidateTrial t;
  t.effect = e;
  t.round = round;
  t.fitted = true;
  t.passed = passed;
  t.heldout_gain = gain;
  t.verdict = std::string(effect_name(e)) + " verdict";
  return t;
}

FitResult fit_marked(double rss) {
  FitResult f;
  f.rss = rss;
  return f;
}

// Round 0 (from the base, rss 100): tilt wins over drift and asymmetry, all
// three passing. Round 1 (from tilt's fit): drift wins over load
// dependence; asymmetry fails.
struct TwoRounds {
  Diagnosis run;
  std::vector<RoundLog> rounds;

  explicit TwoRounds(bool round0_cut = false) {
    run.trials = {trial(Effect::kTiltOffset, 0, true, 0.3), trial(Effect::kDrift, 0, true, 0.2),
                  trial(Effect::kDirectionAsymmetry, 0, true, 0.1), trial(Effect::kDrift, 1, true, 0.05),
                  trial(Effect::kDirectionAsymmetry, 1, false, 0.0), trial(Effect::kLoadDependence, 1, true, 0.04)};
    run.model_before = {1.0, 2.0};
    std::map<Effect, RejectedEffect> status;
    for (Effect e : {Effect::kTiltOffset, Effect::kDrift, Effect::kDirectionAsymmetry, Effect::kLoadDependence}) {
      status[e] = {e, "not examined", std::nullopt, 0.0, std::nullopt};
    }
    record_round_status(run, 0, 0, status);
    RoundLog r0{fit_marked(100), 0, 3, round0_cut, Effect::kTiltOffset, status, {}, std::nullopt, {}};
    r0.passing.emplace(1, fit_marked(1));
    r0.passing.emplace(2, fit_marked(2));
    const AcceptedEffect tilt{Effect::kTiltOffset, {}, run.trials[0], std::nullopt};
    status.erase(Effect::kTiltOffset);
    record_round_status(run, 3, 3, status);
    RoundLog r1{fit_marked(0.5), 3, 6, false, Effect::kDrift, status, {tilt}, std::nullopt, {}};
    r1.passing.emplace(5, fit_marked(5));
    rounds = {r0, r1};
    run.accepted = {tilt, {Effect::kDrift, {}, run.trials[3], std::nullopt}};
  }
};

TEST(RoundLog, TheRoundThatAcceptedARefusedEffectIsWonByTheBestOfTheOthers) {
  TwoRounds log;
  const auto next = resume_without(log.run, log.rounds, {Effect::kTiltOffset}, false, 6);
  ASSERT_TRUE(next.has_value());
  // Round 0 again, without tilt: drift wins it (gain 0.2 over 0.1), with its fit.
  ASSERT_EQ(next->out.trials.size(), 2u);
  EXPECT_EQ(next->out.trials[0].effect, Effect::kDrift);
  EXPECT_EQ(next->out.trials[1].effect, Effect::kDirectionAsymmetry);
  ASSERT_EQ(next->out.accepted.size(), 1u);
  EXPECT_EQ(next->out.accepted[0].effect, Effect::kDrift);
  EXPECT_EQ(next->current.rss, 1);
  EXPECT_EQ(next->next_round, 1);
  EXPECT_EQ(next->out.model_before, (std::vector<double>{1.0, 2.0}));
  // The status as round 0 leaves it: no tilt, drift accepted, asymmetry behind drift.
  EXPECT_EQ(next->status.count(Effect::kTiltOffset), 0u);
  EXPECT_EQ(next->status.count(Effect::kDrift), 0u);
  EXPECT_NE(next->status.at(Effect::kDirectionAsymmetry).reason.find("less than drift"), std::string::npos)
      << next->status.at(Effect::kDirectionAsymmetry).reason;
  ASSERT_EQ(next->rounds.size(), 1u);
  EXPECT_EQ(next->rounds[0].winner, Effect::kDrift);
  ASSERT_EQ(next->rounds[0].passing.size(), 1u);
  EXPECT_EQ(next->rounds[0].passing.at(1).rss, 2);
}

TEST(RoundLog, ALaterRefusalKeepsTheEarlierRoundsRenumbered) {
  TwoRounds log;
  const auto next = resume_without(log.run, log.rounds, {Effect::kDrift}, false, 6);
  ASSERT_TRUE(next.has_value());
  // Round 0 keeps tilt and asymmetry; round 1 is won by load dependence.
  ASSERT_EQ(next->out.trials.size(), 4u);
  EXPECT_EQ(next->out.trials[2].effect, Effect::kDirectionAsymmetry);
  EXPECT_EQ(next->out.trials[3].effect, Effect::kLoadDependence);
  ASSERT_EQ(next->out.accepted.size(), 2u);
  EXPECT_EQ(next->out.accepted[0].effect, Effect::kTiltOffset);
  EXPECT_EQ(next->out.accepted[1].effect, Effect::kLoadDependence);
  EXPECT_EQ(next->current.rss, 5);
  EXPECT_EQ(next->next_round, 2);
  ASSERT_EQ(next->rounds.size(), 2u);
  EXPECT_EQ(next->rounds[0].first_trial, 0u);
  EXPECT_EQ(next->rounds[0].end_trial, 2u);
  EXPECT_EQ(next->rounds[1].first_trial, 2u);
  EXPECT_EQ(next->rounds[1].end_trial, 4u);
  // Drift's passing fit of round 0 is gone; asymmetry's moved to index 1.
  ASSERT_EQ(next->rounds[0].passing.size(), 1u);
  EXPECT_EQ(next->rounds[0].passing.at(1).rss, 2);
  EXPECT_NE(next->status.at(Effect::kDirectionAsymmetry).reason.find("did not clearly help"), std::string::npos);
}

TEST(RoundLog, NoRoundToTakeUpWhenACutRoundFittedARefusedEffect) {
  TwoRounds cut(true);
  EXPECT_FALSE(resume_without(cut.run, cut.rounds, {Effect::kDrift}, false, 6).has_value());
  TwoRounds again(true);
  EXPECT_FALSE(resume_without(again.run, again.rounds, {Effect::kTiltOffset}, false, 6).has_value());
}

TEST(RoundLog, ARoundWithNoOtherPassingTrialEndsTheRounds) {
  TwoRounds log;
  log.run.trials[1].passed = log.run.trials[2].passed = false;
  log.rounds[0].passing.clear();
  const auto next = resume_without(log.run, log.rounds, {Effect::kTiltOffset}, false, 6);
  ASSERT_TRUE(next.has_value());
  EXPECT_TRUE(next->out.accepted.empty());
  EXPECT_EQ(next->current.rss, 100);
  EXPECT_EQ(next->next_round, 6);
}

}  // namespace
}  // namespace tribo::analysis
