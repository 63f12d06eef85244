// What each round of a diagnosis leaves (diagnosis.cc), so that the record
// diagnosed again without an effect it refused takes up from the round that
// accepted the effect, not from the base fit.
//
// Why that is the same diagnosis: before that round the refused effects lost
// every round they were fitted in, and each candidate's signature, score test
// and fit depend on the model it extends only, so without them each earlier
// round fits the same others and takes the same winner. In the round that
// accepted one, the winner is the best of the others that passed, and every
// passing fit is polished in its job, so it is at hand. The one exception is a
// round that cut its candidates (max_candidates_per_round) with a refused one
// among those fitted: without it the next in rank would have been fitted, so
// that record is diagnosed again from the base fit. Tests:
// DiagnosisSynthetic.ARediagnosisTakenUpAtTheRefusedRoundIsTheOneWithoutTheEffect
// (tests/analysis/diagnosis_synthetic_test.cc), RoundLog.* (round_log_test.cc).
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <vector>

#include "analysis/diagnosis.h"

namespace tribo::analysis {

struct RoundLog {
  FitResult current;                            // the model the round extended
  std::size_t first_trial = 0, end_trial = 0;   // its trials, in Diagnosis::trials
  bool cut = false;                             // max_candidates_per_round left candidates out
  std::optional<Effect> winner;
  std::map<Effect, RejectedEffect> status;      // once its trials were judged, the winner still in it
  std::vector<AcceptedEffect> accepted;         // before its winner
  std::optional<BaseContactChoice> base_contact;  // before its winner
  std::map<std::size_t, FitResult> passing;     // the fits of its passing trials but the winner's
};

// A diagnosis's state after the round that first accepted a refused effect,
// as a diagnosis without the refused effects reaches it.
struct ResumedRounds {
  Diagnosis out;  // the base fit, model_before and before, the trials and acceptances so far
  std::map<Effect, RejectedEffect> status;
  std::vector<RoundLog> rounds;
  FitResult current;
  int next_round = 0;  // the rounds are over when it reaches max_rounds
  bool velocity_steps_on_lugre = false;
};

// The round's winner among trials [first, end): the passing trial of the
// largest held-out gain, the first of equals.
std::optional<std::size_t> best_trial(const std::vector<CandidateTrial>& trials, std::size_t first, std::size_t end);

// The round's winner accepted into out: its status entry goes, and a contact
// law it was fitted without leaves the model (take_out_contact_law).
void accept_winner(const CandidateTrial& winner, std::map<Effect, RejectedEffect>& status, Diagnosis& out);

// Each fitted candidate's reason after its round (trials from first_trial
// on): refused with its verdict, or helped less than the round's winner.
void record_round_status(const Diagnosis& out, std::size_t first_trial, std::optional<std::size_t> best,
                         std::map<Effect, RejectedEffect>& status);

// The rounds of `run` without the refused effects, up to and with the first
// round whose winner is refused; std::nullopt where a round before cut its
// candidates with a refused one among them. Takes the base fit, the model
// before, the trials and the rounds' fits from run and rounds.
std::optional<ResumedRounds> resume_without(Diagnosis& run, std::vector<RoundLog>& rounds,
                                            const std::vector<Effect>& refused, bool velocity_steps_on_lugre,
                                            int max_rounds);

}  // namespace tribo::analysis
