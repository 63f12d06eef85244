// The contact law as a decision on held-out data ("base-model
// choice"): plain LuGre, LuGre with elasto-plastic presliding and with
// rate-and-state dependence (nested), the rate-and-state contact in place of
// the Stribeck curve, and on one-way records each with a friction level
// linear in the distance slid; the one kept and the evidence for each.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "analysis/models/evaluated_fit.h"

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
  // Why the chosen law is no longer in the final model, if so: an effect
  // accepted later was fitted without it (CandidateTrial::law_left).
  std::string left_model;
};

struct ContactChoiceOptions {
  FitOptions candidate_fit;       // each law's fit on top of the last (capped)
  FitOptions polish;              // the kept contact's fit to convergence
  double min_heldout_gain = 0;    // a richer contact must lower the held-out RMS by this share (DiagnosisOptions')
  unsigned threads = 0;           // fits made at once (0: one per core); the result does not depend on it
};

// What the choice among contacts goes by, per contact (LuGre first).
struct ContactEvidence {
  std::string name;
  double heldout_rms = 0;
  bool physical = true;        // no value past a bound
  bool names_its_law = true;   // not a rate-and-state law with a <= 0 or b <= -a, nor a trend of half the level
  int free_parameters = 0;
  std::map<int, double> block_sse;  // held-out sum of squared errors per held-out block
};

struct ContactPick {
  std::size_t index = 0;  // into the evidence
  std::string warning;    // when LuGre is past a bound and the pick is not one that predicts no worse
};

// Per held-out block (MotionSegmentation::block_of: a pass, or a time chunk
// of a one-pass record), the model's sum of squared errors.
std::map<int, double> heldout_block_sse(const ModelData& data, const std::vector<double>& model, const std::vector<char>& heldout);

// How far one model's held-out mean squared error lies above another's, in
// standard errors of that difference, the held-out blocks taken as the
// independent units (the residual is correlated within a block). Infinite
// with fewer than two blocks: no error to judge by.
double excess_in_standard_errors(const std::map<int, double>& sse, const std::map<int, double>& reference);

// Why a contact's fit is not physical: the base model's values past their
// bounds, each added law's, and a slip trend of more than half the level
// over the record's slip (empty when it is physical).
std::string contact_objection(const ModelData& data, const FitResult& fit);

// The rule of choose_base_contact below, on the evidence alone: among the
// physical contacts predicting no worse than LuGre, LuGre then by free
// parameters, fewest first, each kept over the last when it lowers the
// held-out RMS by min_heldout_gain. With none, and LuGre past a bound, the
// physical contacts within one standard error (over the held-out blocks) of
// the best-predicting one; with none still, every contact that names its law.
ContactPick pick_contact(const std::vector<ContactEvidence>& evidence, double min_heldout_gain);

// The nested contact laws, each fitted on top of the last as its extension
// from the residual signature's starting values, and the rate-and-state
// contact; one kept by pick_contact (its bounds: the base's and each added
// law's), with a warning when the rule had to go past "physical and no worse
// than LuGre" (DiagnosisOptions::choose_base_contact). current is the LuGre
// base fit on entry and the kept contact's fit on return.
BaseContactChoice choose_base_contact(const ModelData& data, const ContactChoiceOptions& options, const std::vector<char>& in_fit,
                                      const std::vector<char>& heldout, EvaluatedFit& current);

}  // namespace tribo::analysis
