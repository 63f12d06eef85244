// Residual diagnosis: fit the base LuGre model, look at what it gets wrong,
// trace the residual to the effect the model lacks, add it, refit, and report
// the error before and after.
//
// Each round: every candidate effect not yet accepted gets its residual
// signature (analysis/effects/residual_signatures.h) on the fit samples and a score
// test (the residual regressed on the extension's sensitivities, the one
// statistic comparable across effects, used to rank); those showing the
// effect are fitted as extensions of the present model (first the new
// parameters with the base parameters they re-partition with, from the
// signature's initial values, the best of a few starts for time and length
// scales, then everything together). A candidate is accepted only if it
// clearly helps on the held-out passes:
//   - held-out RMS error at least min_heldout_gain lower,
//   - on the held-out blocks (passes) holding at least min_block_agreement
//     of its change, each block weighted by the candidate's squared change
//     of the model force there,
//   - and AICc lower by at least -max_delta_aicc. AICc counts every fit
//     sample; with autocorrelated residuals that overstates the evidence, so
//     the AICc change with the effective sample count (from the residual's
//     lag-1 autocorrelation) is reported beside it. The decision rests on the
//     held-out error,
//   - within its physical bounds, with a strength min_strength_z standard
//     errors clear of no effect.
// The best passing candidate (largest held-out gain) is accepted, the model
// polished to convergence, and the loop repeats; it stops when nothing passes. Structure left in the residual that
// no candidate explains is described (the regressor it follows), never
// labelled with an effect that did not pass.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "analysis/models/contact_choice.h"
#include "analysis/effects/confusion.h"
#include "analysis/effects/creep_in_holds.h"
#include "analysis/effects/detectability.h"
#include "analysis/effects/drift_knot_choice.h"
#include "analysis/effects/effect.h"
#include "analysis/models/evaluated_fit.h"
#include "analysis/models/friction_model.h"
#include "analysis/models/lugre_fit.h"
#include "analysis/input/measured_series.h"
#include "analysis/models/model_adequacy.h"
#include "analysis/models/model_fit.h"
#include "analysis/motion/motion_segmentation.h"
#include "analysis/report/phase_timings.h"
#include "analysis/effects/residual_signatures.h"

namespace tribo::analysis {

// The base model's unresolved-dither term (ModelStructure::unresolved_dither):
// left out, always in, or kept where it predicts the held-out passes better
// (tribo-fit --dither).
enum class DitherTerm { off, on, choose };

// The evidence for the unresolved-dither term (DitherTerm::choose): the base
// fitted without and with it, each judged on the held-out samples.
struct DitherChoice {
  double heldout_rms_without = 0, heldout_rms_with = 0;  // force units
  // The held-out mean squared error without the dither above that with it,
  // in standard errors of the difference over the held-out blocks.
  double excess_se_without = 0;
  std::string objection;  // the dithered base's values past a bound, if any
  double dither_speed_m_per_s = 0, dither_speed_se = 0;
  bool chosen = false;
};

struct DiagnosisOptions {
  ModelStructure base;                                   // load scaling, mass, Stribeck exponent
  DitherTerm dither = DitherTerm::off;
  std::vector<Effect> candidates{kAllEffects.begin(), kAllEffects.end()};
  SegmentationOptions segmentation;
  LugreFitOptions lugre;
  FitOptions candidate_fit{15, 1e-6};
  double min_signature_strength = 1.0;   // max(signature strength, score t / score_t_threshold)
  double score_t_threshold = 2.0;
  double min_heldout_gain = 0.02;
  double min_block_agreement = 0.75;
  double max_delta_aicc = -10.0;
  // An accepted effect's strength must stand this many standard errors from
  // no effect: a 5 % chance of a false acceptance over the eleven candidates
  // of a round (Bonferroni) needs |z| >= 2.84 each, rounded up to 3.
  double min_strength_z = 3.0;
  int max_candidates_per_round = 10;
  int max_rounds = 6;
  unsigned threads = 0;  // candidates fitted at once (0: one per core); the result does not depend on it
  PhaseTimings* timings = nullptr;  // each phase's time and work (tribo-fit diagnose --timings); none: null
  // Leave base.state_from_rest to the data: diagnose the record both ways and
  // keep the one whose final model has the lower held-out error over the
  // passes (the holds are not compared: with the state from the force they
  // are not modelled). Twice the work, on records with holds.
  bool choose_state_from_rest = false;
  // For each effect not accepted: the strength this record would reveal
  // (analysis/effects/detectability.h).
  bool minimum_detectable = true;
  // The contact law as a decision on held-out data ("base-model
  // choice"): plain LuGre, LuGre with Dupont's elasto-plastic presliding, and
  // that with the rate-and-state dependence (the simulated instrument's
  // default contact), nested (a law whose signature does not apply is
  // skipped); where the record has speed steps, also the rate-and-state
  // contact in place of the Stribeck curve, viscous term and bristle
  // damping; among those within physical bounds (LuGre too), a richer
  // contact is kept when it lowers the held-out RMS by min_heldout_gain. The chosen contact's extensions are
  // part of the base, not accepted effects. Off by default (tribo-fit
  // --base-model choose).
  bool choose_base_contact = false;
  // The same record with its motion estimated by other motion models (same
  // samples): the final model is refitted on each, and each parameter's
  // largest shift over those under which the model still predicts the
  // held-out passes (within kMaxAlternativeMotionRatio) is its motion-model
  // systematic error (ParamEstimate::motion_systematic), added to its standard
  // error in quadrature. Decisions are taken before, on the errors without
  // it. Only their motion columns are read (keep_motion_only(),
  // analysis/input/measured_series.h).
  std::vector<const MeasuredSeries*> alternative_motions;
  // Called once the diagnosis no longer reads alternative_motions: when it
  // keeps what it accepted, before the minimum detectable strengths, its
  // costliest phase in memory, so that the caller can free them.
  std::function<void()> alternative_motions_done;
  // The confusion check (analysis/effects/confusion.h): each accepted effect
  // against every other effect of `rivals` (empty: the candidates) that
  // applies to the record. With min_confusion_z > 0 an effect whose nearest
  // rival leaves less than this z of it is refused, and the record is
  // diagnosed again without it as a candidate; 0: reported only.
  double min_confusion_z = 0;
  std::vector<Effect> rivals;
  // After a refusal, take the diagnosis without the refused effects up from
  // the round that accepted the first of them (analysis/round_log.h); false:
  // from the base fit. The same diagnosis either way; false is for the test
  // that says so.
  bool resume_at_refused_round = true;
};

// The evidence for the state each pass starts from, when it was chosen.
// Where each pass starts, chosen on the final models' held-out pass RMS
// (diagnosis.cc, diagnose_both_pass_starts). Force units, over held-out
// pass samples (holds excluded: one of the two does not model them).
struct PassStartChoice {
  double heldout_rms_modelled_holds = 0;  // the base fits'
  double heldout_rms_state_from_rest = 0;
  double final_heldout_rms_modelled_holds = 0;  // the final models': these decide
  double final_heldout_rms_state_from_rest = 0;
  bool state_from_rest = false;                 // the choice
  std::string objection;                        // the other start's final base past its physical bounds (information)
};

struct ModelErrors {
  ErrorStats fit, heldout, all;
};

struct ConditionError {
  std::string condition;  // e.g. "direction +", "speed 5e-07 m/s", "load 0.001 N"
  std::size_t n = 0;
  double rms_before = 0, rms_after = 0;
};

struct CandidateTrial {
  Effect effect = Effect::kDrift;
  int round = 0;
  Signature signature;
  bool fitted = false;
  double delta_aicc = 0;             // with the fit sample count
  double delta_aicc_effective = 0;   // with the effective sample count
  double heldout_rms_before = 0, heldout_rms_after = 0;
  double heldout_gain = 0;       // 1 - after / before
  double block_agreement = 0;    // share of the held-out change (sum of squares) in blocks that improved
  bool passed = false;
  std::string verdict;
  // A contact law of the model that the candidate's fit took past its bound,
  // the candidate then fitted and judged without it: accepted, the law
  // leaves the model.
  std::optional<Effect> law_left;
  std::vector<ParamEstimate> parameters;  // the effect's, from the trial fit
  std::vector<std::string> warnings;
};

struct AcceptedEffect {
  Effect effect = Effect::kDrift;
  std::vector<ParamEstimate> parameters;  // from the final fit
  CandidateTrial trial;                   // the round it was accepted in
  std::optional<EffectConfusion> confusion;  // against its rivals, on the final model
};

struct RejectedEffect {
  Effect effect = Effect::kDrift;
  std::string reason;
  std::optional<CandidateTrial> last_trial;  // when it was fitted
  double signature_strength = 0;
  std::optional<DetectableStrength> minimum_detectable;  // with DiagnosisOptions::minimum_detectable
};

struct Diagnosis {
  MotionSegmentation motion;
  LugreFit base;
  std::optional<PassStartChoice> pass_start;
  std::optional<BaseContactChoice> base_contact;
  std::optional<DitherChoice> dither;  // DitherTerm::choose
  std::optional<DriftKnotChoice> drift_knots;  // when drift is a candidate
  // Drift as a creep under a stuck contact, assessed on records with holds
  // of minutes (analysis/effects/creep_in_holds.h); accepted, drift is accepted with it.
  std::optional<CreepInHolds> creep;
  FitResult final_fit;
  // Whether the final model describes the record (analysis/models/model_adequacy.h):
  // when it does not, no effect is accepted (those the rounds took are in
  // rejected, with the reason).
  ModelAdequacy adequacy;
  std::vector<AcceptedEffect> accepted;
  std::vector<RejectedEffect> rejected;
  std::vector<CandidateTrial> trials;     // every fitted candidate, in order
  ModelErrors before, after;
  std::vector<ConditionError> heldout_by_condition;
  std::optional<std::string> unexplained;
  std::vector<std::string> warnings;
  std::vector<double> model_before, model_after;  // model force per sample
  double noise_floor = 0;                         // white-noise RMS of the final residual
};

// The contact law a round's winner was accepted without
// (CandidateTrial::law_left) leaves the model: a law accepted in an earlier
// round is withdrawn (status says why; it is a candidate again in the rounds
// that follow), a law of the contact choice is said to have left the base
// (BaseContactChoice::left_model).
void take_out_contact_law(const CandidateTrial& winner, std::map<Effect, RejectedEffect>& status, Diagnosis& out);

// series must have velocity and acceleration (derive_motion()).
Diagnosis diagnose(const MeasuredSeries& series, const DiagnosisOptions& options = {});

// The motion estimate the friction analysis can use, by how well the base
// model predicts the measured force on held-out data under each of several
// estimates of one record (the same samples, each with velocity and
// acceleration; the first is the default): the diagnosis' base LuGre fit
// (options.base, options.lugre) on the fit samples of one segmentation (the
// first estimate's), its RMS error over the held-out pass samples (holds
// excluded, as where each pass starts is chosen). Where the diagnosis tries
// both pass starts (options.choose_state_from_rest, a record with holds)
// each estimate gets the better of its two base fits. Another estimate
// replaces the first only if it lowers that RMS by options.min_heldout_gain
// and its held-out mean squared error lies at least one standard error of
// the difference (over the held-out passes) below the first's, as a richer
// contact must (analysis/models/contact_choice.h); of those, the lowest RMS.
// Returns each estimate's figures, the chosen one marked.
std::vector<MotionModelEvidence> weigh_motion_estimates(const std::vector<const MeasuredSeries*>& estimates,
                                                        const DiagnosisOptions& options = {});


}  // namespace tribo::analysis
