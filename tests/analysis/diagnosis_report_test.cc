// The diagnosis' text report, on a Diagnosis set out here.
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "analysis/diagnosis.h"
#include "analysis/diagnosis_report.h"

namespace tribo::analysis {
namespace {

// Each contact tried is set beside the chosen one: an option that predicts
// better (past a bound, or not by the gain) is said to lie below it, never
// "-2.20 standard errors above"; its laws' values come with their errors.
TEST(DiagnosisReport, EachContactOptionIsSaidToLieAboveOrBelowTheChosen) {
  MeasuredSeries s;
  Diagnosis d;
  d.base_contact = BaseContactChoice{};
  d.base_contact->chosen = "lugre";
  const double one_block = std::numeric_limits<double>::infinity();
  d.base_contact->options = {{"lugre", 1.0, "", {}, 6, 0.0},
                             {"lugre+elasto_plastic", 0.9, "fitted breakaway_ratio 0.995 is at a bound", {}, 7, -2.2},
                             {"rate_state_contact", 1.2, "", {{"rs_a", "1", 0.0116, 0.0011, false, true, Effect::kRateState}}, 5, 1.5},
                             {"lugre+rate_state", 1.1, "", {}, 9, one_block}};
  const std::string text = diagnosis_text(s, d);
  EXPECT_NE(text.find("held-out RMS 1 (chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(2.20 standard errors below the chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(1.50 standard errors above the chosen)"), std::string::npos) << text;
  EXPECT_NE(text.find("(one held-out block: no standard error against the chosen)"), std::string::npos) << text;
  EXPECT_EQ(text.find("-2.20"), std::string::npos) << text;
  EXPECT_NE(text.find("rs_a 0.0116 +- 0.0011 1"), std::string::npos) << text;
}

}  // namespace
}  // namespace tribo::analysis
