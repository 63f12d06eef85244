// Physical bounds on a fitted model ("honest numbers"): why a
// candidate's fit cannot be accepted whatever its held-out gain (a parameter
// at or past its bound or below what the record resolves, a strength its
// error does not determine, a contact law it moves past its bounds, a tilt
// the rest force contradicts), and the base model's impossible values, which
// are warnings since the base cannot be refused.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {

// The smallest length these data resolve: the position's resolution or its
// noise floor, whichever is larger (never zero).
double resolved_length_m(const MeasuredSeries& s);

// Why a fitted extension is not the physical effect (a parameter at or past
// its physical bound, or below what the data resolve), or empty.
std::string out_of_bounds(const ModelData& data, const FitResult& fit, Effect effect);

// Why a rate-and-state law with direct effect a and evolution b is not
// rate-and-state friction (a <= 0, or b <= -a: an evolution that undoes the
// direct effect), or empty. Part of out_of_bounds; the contact choice keeps
// no such law even when no contact is within its bounds.
std::string rate_state_sign_objection(double a, double b);

// An extension's strength parameters fewer than min_z standard errors from
// the value with the effect off (jointly, by a Wald test, where it has
// several), with the reason; empty when the strength is determined.
std::string undetermined_strength(const ModelData& data, const FitResult& fit, Effect effect, double min_z);

// The contact laws already in the model (rate_state, presliding_hysteresis)
// refitted past their bounds with a candidate, with the reason; empty when
// they stay within them.
std::string contact_law_objection(const ModelData& data, const FitResult& fit, Effect effect);

// The first contact law already in the model that a candidate's fit refits
// past its bound (contact_law_objection's), if any.
std::optional<Effect> contact_law_past_bound(const ModelData& data, const FitResult& fit, Effect effect);

// Why a candidate's fit cannot be accepted whatever its held-out gain
// (out_of_bounds, contact_law_objection, undetermined_strength, and for a
// tilt the rest force), or empty; model is the fit's model force.
std::string candidate_objection(const ModelData& data, const FitResult& fit, Effect effect,
                                const std::vector<double>& model, double min_strength_z);

// The base model's values past physical bounds (base_out_of_bounds,
// analysis/models/lugre_fit.h) and an unresolved presliding deflection, as warnings.
std::vector<std::string> base_bound_warnings(const ModelData& data, const FitResult& fit);

// The base model's values past their physical bounds, in one line (empty
// when there are none).
std::string base_objection(const ModelData& data, const FitResult& fit);

}  // namespace tribo::analysis
