// A contact law that a round's winner was accepted without leaves the model
// (take_out_contact_law, analysis/diagnosis.h): a law accepted in an earlier
// round is withdrawn and becomes a candidate again; a law of the contact
// choice is said to have left the base.
#include <utility>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"

namespace tribo::analysis {
namespace {

CandidateTrial tilt_without_rate_state() {
  CandidateTrial t;
  t.effect = Effect::kTiltOffset;
  t.round = 2;
  t.passed = true;
  t.verdict = "held-out RMS 27 -> 2 uN";
  t.law_left = Effect::kRateState;
  return t;
}

AcceptedEffect accepted_in_round(Effect effect, int round) {
  AcceptedEffect a;
  a.effect = effect;
  a.trial.effect = effect;
  a.trial.round = round;
  return a;
}

TEST(ContactLawWithdrawal, ALawAcceptedInAnEarlierRoundIsWithdrawnAndIsACandidateAgain) {
  Diagnosis d;
  d.accepted = {accepted_in_round(Effect::kDrift, 0), accepted_in_round(Effect::kRateState, 1)};
  std::map<Effect, RejectedEffect> status;  // the candidates not in the model
  status[Effect::kBacklash] = {Effect::kBacklash, "not examined", std::nullopt, 0.0, std::nullopt};
  take_out_contact_law(tilt_without_rate_state(), status, d);

  ASSERT_EQ(d.accepted.size(), 1u);
  EXPECT_EQ(d.accepted[0].effect, Effect::kDrift);
  ASSERT_EQ(status.count(Effect::kRateState), 1u);
  const RejectedEffect& law = status.at(Effect::kRateState);
  EXPECT_EQ(law.reason.rfind("withdrawn: round 3's tilt_offset was accepted without it: held-out RMS 27 -> 2 uN", 0), 0u)
      << law.reason;
  ASSERT_TRUE(law.last_trial);
  EXPECT_EQ(law.last_trial->round, 1) << "the trial it was accepted in";
  EXPECT_EQ(status.at(Effect::kBacklash).reason, "not examined");
}

TEST(ContactLawWithdrawal, ALawOfTheContactChoiceLeavesTheBase) {
  Diagnosis d;
  BaseContactChoice contact;
  contact.chosen = "rate_state_contact";
  d.base_contact = std::move(contact);
  d.accepted = {accepted_in_round(Effect::kDrift, 0)};
  std::map<Effect, RejectedEffect> status;
  take_out_contact_law(tilt_without_rate_state(), status, d);

  EXPECT_EQ(d.accepted.size(), 1u) << "an effect that is not the law stays";
  EXPECT_TRUE(status.empty()) << "the base's law is not a candidate";
  EXPECT_EQ(d.base_contact->left_model.rfind("rate_state left the model: round 3's tilt_offset", 0), 0u)
      << d.base_contact->left_model;
}

}  // namespace
}  // namespace tribo::analysis
