#include "analysis/round_log.h"

#include <algorithm>
#include <string>
#include <utility>

namespace tribo::analysis {

void record_round_status(const Diagnosis& out, std::size_t first_trial, std::optional<std::size_t> best,
                         std::map<Effect, RejectedEffect>& status) {
  for (std::size_t k = first_trial; k < out.trials.size(); ++k) {
    const CandidateTrial& t = out.trials[k];
    RejectedEffect& st = status[t.effect];
    st.last_trial = t;
    if (!t.passed) st.reason = "fitted but did not clearly help on held-out data: " + t.verdict;
    else if (best && k != *best) st.reason = "helped, but less than " + std::string(effect_name(out.trials[*best].effect)) + " this round: " + t.verdict;
  }
}

std::optional<std::size_t> best_trial(const std::vector<CandidateTrial>& trials, std::size_t first, std::size_t end) {
  std::optional<std::size_t> best;
  for (std::size_t k = first; k < end; ++k) {
    if (trials[k].passed && (!best || trials[k].heldout_gain > trials[*best].heldout_gain)) best = k;
  }
  return best;
}

void accept_winner(const CandidateTrial& winner, std::map<Effect, RejectedEffect>& status, Diagnosis& out) {
  out.accepted.push_back({winner.effect, {}, winner, std::nullopt});
  status.erase(winner.effect);
  if (winner.law_left) take_out_contact_law(winner, status, out);
}

namespace {

std::map<Effect, RejectedEffect> without(std::map<Effect, RejectedEffect> status, const std::vector<Effect>& refused) {
  for (Effect e : refused) status.erase(e);
  return status;
}

}  // namespace

std::optional<ResumedRounds> resume_without(Diagnosis& run, std::vector<RoundLog>& rounds,
                                            const std::vector<Effect>& refused, bool velocity_steps_on_lugre,
                                            int max_rounds) {
  const auto is_refused = [&](Effect e) { return std::find(refused.begin(), refused.end(), e) != refused.end(); };
  const auto first = std::find_if(rounds.begin(), rounds.end(), [&](const RoundLog& r) { return r.winner && is_refused(*r.winner); });
  if (first == rounds.end()) return std::nullopt;
  for (auto r = rounds.begin(); r <= first; ++r) {
    if (!r->cut) continue;
    for (std::size_t k = r->first_trial; k < r->end_trial; ++k) {
      if (is_refused(run.trials[k].effect)) return std::nullopt;
    }
  }
  // The trials kept; kept_before[k]: how many of them precede old index k.
  std::vector<char> kept(first->end_trial);
  std::vector<std::size_t> kept_before(first->end_trial + 1, 0);
  for (std::size_t k = 0; k < first->end_trial; ++k) {
    kept[k] = !is_refused(run.trials[k].effect);
    kept_before[k + 1] = kept_before[k] + (kept[k] ? 1 : 0);
  }
  ResumedRounds next;
  for (std::size_t k = 0; k < first->end_trial; ++k) {
    if (kept[k]) next.out.trials.push_back(std::move(run.trials[k]));
  }
  const auto renumbered = [&](RoundLog& r) {
    RoundLog m{std::move(r.current), kept_before[r.first_trial], kept_before[r.end_trial], r.cut, r.winner,
               without(std::move(r.status), refused), std::move(r.accepted), std::move(r.base_contact), {}};
    for (auto& [k, fit] : r.passing) {
      if (kept[k]) m.passing.emplace(kept_before[k], std::move(fit));
    }
    return m;
  };
  for (auto r = rounds.begin(); r != first; ++r) next.rounds.push_back(renumbered(*r));
  // The round that accepted a refused effect, judged again without it.
  RoundLog round = renumbered(*first);
  round.winner.reset();
  next.status = round.status;
  next.out.accepted = round.accepted;
  next.out.base_contact = round.base_contact;
  const std::optional<std::size_t> best = best_trial(next.out.trials, round.first_trial, round.end_trial);
  record_round_status(next.out, round.first_trial, best, next.status);
  round.status = next.status;
  const int number = static_cast<int>(next.rounds.size());
  if (best) {
    const CandidateTrial& winner = next.out.trials[*best];
    round.winner = winner.effect;
    next.current = std::move(round.passing.at(*best));
    round.passing.erase(*best);
    accept_winner(winner, next.status, next.out);
    next.next_round = number + 1;
  } else {
    next.current = round.current;
    next.next_round = max_rounds;
  }
  next.rounds.push_back(std::move(round));
  // The part before the rounds: a drift knot choice only with drift a candidate.
  next.out.base = std::move(run.base);
  next.out.dither = std::move(run.dither);
  next.out.before = run.before;
  next.out.model_before = std::move(run.model_before);
  if (!is_refused(Effect::kDrift)) next.out.drift_knots = std::move(run.drift_knots);
  next.velocity_steps_on_lugre = velocity_steps_on_lugre;
  return next;
}

}  // namespace tribo::analysis
