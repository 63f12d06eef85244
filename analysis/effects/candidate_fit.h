// How a candidate extension of the vocabulary is fitted on top of the current
// model: screened by a score test at its signature's starting values, then
// fitted (its own parameters first, with the base parameters it shares, then
// everything), from more than one start where a base curve can have taken up
// the effect.
#pragma once

#include <vector>

#include "analysis/models/model_fit.h"
#include "analysis/effects/residual_signatures.h"

namespace tribo::analysis {

// Score (Lagrange-multiplier) test of the extension at the signature's
// starting values on the current model: the largest |t| of the present
// residual regressed on its sensitivities (autocorrelation-inflated errors),
// comparable across effects.
double score_test(const ModelData& data, const ModelParams& current, const std::vector<double>& current_model,
                  Effect effect, const Signature& sig, const std::vector<char>& in_fit);

// The extension fitted on top of current (the starts and forms in the
// definition's comment); candidate_fit caps the iterations.
FitResult fit_extension(const ModelData& data, const ModelParams& current, Effect effect, const Signature& sig,
                        const std::vector<char>& in_fit, const FitOptions& candidate_fit);

// Whether current's Stribeck curve rises from the static level to the
// Coulomb one: a friction that strengthens with speed, taken up by the base.
// Not for a curve held flat (the rate-and-state contact fixes mu_s = mu_c).
bool stribeck_rises(const ModelParams& current);

// current with the Stribeck curve's shape (static level, Stribeck velocity,
// viscous and bristle damping) back at the base model's default start.
ModelParams with_default_stribeck(const ModelData& data, const ModelParams& current);

// Whether the extension's fit re-partitions with the Stribeck curve's
// velocity scale: a velocity dependence the base curve took up can move into
// it, or out of it.
bool repartitions_with_stribeck(Effect effect);

// A candidate fit's relative cost (free parameters times fits), for the order
// the round's jobs start in.
double expected_fit_cost(const ModelData& data, const ModelParams& current, Effect effect);

}  // namespace tribo::analysis
