// The contact law as a decision on held-out data (issue 15, "base-model
// choice"): plain LuGre, LuGre with elasto-plastic presliding and with
// rate-and-state dependence (nested), the rate-and-state contact in place of
// the Stribeck curve, and on one-way records each with a friction level
// linear in the distance slid; the one kept and the evidence for each.
#pragma once

#include <string>
#include <vector>

#include "analysis/evaluated_fit.h"

namespace tribo::analysis {

// The contact laws tried as the base model and the one kept.
struct BaseContactChoice {
  struct Option {
    // "lugre", "lugre+elasto_plastic", "lugre+elasto_plastic+rate_state" (nested;
    // "lugre+rate_state" when presliding is not resolved), "rate_state_contact"
    // (rate-and-state in place of the Stribeck curve; velocity-step records),
    // and on one-way records each again with "slip_trend" (docs/tribo_fit.md)
    std::string name;
    double heldout_rms = 0;   // force units, over the held-out samples
    std::string note;         // why its fit is not physical (a value past a bound), if so
    std::vector<ParamEstimate> parameters;  // its fitted values, base and laws
    int free_parameters = 0;  // of those, the ones fitted (not held)
    // Its held-out mean squared error above the chosen contact's, in standard
    // errors of the difference over the held-out blocks (0 for the chosen;
    // negative: better, yet not by the gain; infinite with one block).
    double heldout_excess_se = 0;
  };
  std::vector<Option> options;
  std::string chosen;
  std::string not_tried;      // why a richer law was not tried, if so ("; "-separated)
  std::string warning;        // when no contact tried was physical
};

struct ContactChoiceOptions {
  FitOptions candidate_fit;       // each law's fit on top of the last (capped)
  FitOptions polish;              // the kept contact's fit to convergence
  double min_heldout_gain = 0;    // a richer contact must lower the held-out RMS by this share (DiagnosisOptions')
};

// The nested contact laws, each fitted on top of the last as its extension
// from the residual signature's starting values. Among the contacts whose
// fits are physical (the base's bounds and each added law's) and predict the
// held-out data no worse than LuGre, taken from LuGre and then by free
// parameters, fewest first, one is kept over the last kept when it lowers the
// held-out RMS by options.min_heldout_gain. When none is physical, the bounds
// are let go (never those that make a fit not the law it names: a
// rate-and-state law with a <= 0 or b <= -a, a slip trend of half the
// level), with a warning (DiagnosisOptions::choose_base_contact). current is
// the LuGre base fit on entry and the kept contact's fit on return.
BaseContactChoice choose_base_contact(const ModelData& data, const ContactChoiceOptions& options, const std::vector<char>& in_fit,
                                      const std::vector<char>& heldout, EvaluatedFit& current);

}  // namespace tribo::analysis
