// The rule that keeps one contact among those tried (pick_contact), on
// evidence set out here: held-out RMS, bounds, and the held-out blocks'
// squared errors the standard errors come from.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/models/contact_choice.h"

namespace tribo::analysis {
namespace {

// Eight held-out blocks, each with squared error sse_per_block plus a
// block-to-block scatter (alternately + and -) that sets the standard error
// of a difference between two contacts.
ContactEvidence contact(const std::string& name, double sse_per_block, double scatter, bool physical, int free_parameters) {
  ContactEvidence c;
  c.name = name;
  c.physical = physical;
  c.free_parameters = free_parameters;
  double total = 0;
  for (int b = 0; b < 8; ++b) {
    c.block_sse[b] = sse_per_block + (b % 2 == 0 ? scatter : -scatter);
    total += c.block_sse[b];
  }
  c.heldout_rms = std::sqrt(total / 8);
  return c;
}

// A physical contact that predicts better than LuGre by more than the gain
// is kept, and nothing is to be warned about.
TEST(ContactChoice, APhysicalContactThatPredictsBetterIsKept) {
  const std::vector<ContactEvidence> e{contact("lugre", 100, 0, true, 6), contact("rate_state_contact", 80, 5, true, 5)};
  const ContactPick pick = pick_contact(e, 0.02);
  EXPECT_EQ(pick.index, 1u);
  EXPECT_TRUE(pick.warning.empty());
}

// LuGre past a bound, and a physical contact the held-out blocks cannot tell
// from it (4 % more squared error, with a scatter that puts the difference
// well within one standard error): the physical one is kept, and the report
// says why (sepiolite velstep1 with the speed steps as jumps, the contact fitted from one start:
// 3.9 % worse, 0.10 standard errors).
TEST(ContactChoice, APhysicalContactWithinOneStandardErrorIsKeptOverLugrePastABound) {
  const std::vector<ContactEvidence> e{contact("lugre", 100, 0, false, 6), contact("rate_state_contact", 104, 30, true, 5)};
  const ContactPick pick = pick_contact(e, 0.02);
  EXPECT_EQ(pick.index, 1u);
  EXPECT_NE(pick.warning.find("within 1 standard error"), std::string::npos) << pick.warning;
}

// The same, but the blocks agree that the physical contact is worse (no
// scatter: many standard errors): LuGre is kept on held-out error alone, with
// the warning that every contact is past a bound or predicts worse.
TEST(ContactChoice, APhysicalContactClearlyWorseLeavesLugrePastItsBound) {
  const std::vector<ContactEvidence> e{contact("lugre", 100, 0, false, 6), contact("rate_state_contact", 104, 0.5, true, 5)};
  const ContactPick pick = pick_contact(e, 0.02);
  EXPECT_EQ(pick.index, 0u);
  EXPECT_NE(pick.warning.find("every contact law tried"), std::string::npos) << pick.warning;
}

// Among physical contacts that predict no worse than LuGre, the one with
// fewer free parameters is kept unless the richer lowers the held-out RMS by
// the gain (2 %).
TEST(ContactChoice, FewerParametersFirstAndARicherOneMustEarnThem) {
  const std::vector<ContactEvidence> e{contact("lugre", 100, 0, true, 6), contact("lugre+rate_state", 95, 0, true, 9),
                                       contact("rate_state_contact", 96, 0, true, 5)};
  EXPECT_EQ(pick_contact(e, 0.02).index, 2u);
  const std::vector<ContactEvidence> richer_better{contact("lugre", 100, 0, true, 6), contact("lugre+rate_state", 85, 0, true, 9),
                                                   contact("rate_state_contact", 96, 0, true, 5)};
  EXPECT_EQ(pick_contact(richer_better, 0.02).index, 1u);
}

}  // namespace
}  // namespace tribo::analysis
