// Whether the final model describes the record at all. Effects are named
// only on a model that does: one fitted past a physical bound (a negative
// viscous coefficient, a friction coefficient past its bounds) is the wrong
// form bent to fit, and any effect added to it names that misfit, not a
// physical effect. The report then says so and names no effect; the fitted
// values stay in it as information.
#pragma once

#include <string>
#include <vector>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {

struct ModelAdequacy {
  bool describes_record = true;
  std::vector<std::string> reasons;  // why not, one line each; empty when it does
};

// The final model's base values against their physical bounds: those of
// base_out_of_bounds (analysis/models/lugre_fit.h), and a viscous coefficient whose
// 95 % interval lies below zero (negative viscous friction is not physical,
// however small; one within its error of zero is).
ModelAdequacy judge_model_adequacy(const ModelData& data, const FitResult& final_fit);

}  // namespace tribo::analysis
