// The dynamic LuGre fit with global initialisation, not hand-picked guesses:
//   1. a linear least-squares pass (F ~ Fc sgn(v) + Fv v + offset [+ M a]) for
//      the offset and the inertia,
//   2. the steady-state Stribeck curve (analysis/models/stribeck_fit.h) on sliding
//      samples binned by velocity, for Fc, Fs, vs, Fv,
//   3. a grid of presliding lengths Fc/sigma0 (1e-4 to 1 times the median
//      pass length, half a decade apart) and damping levels sigma1
//      (multi-start), each simulated once; the best few are refined by the
//      simulation-error fit (analysis/models/model_fit.h) and the best one within
//      the base model's physical bounds is kept (the best of all when none
//      is).
#pragma once

#include <string>
#include <vector>

#include "analysis/models/friction_model.h"
#include "analysis/models/model_fit.h"
#include "analysis/models/stribeck_fit.h"

namespace tribo::analysis {

struct LugreFitOptions {
  FitOptions fit;
  int refined_starts = 2;  // how many of the grid's starts get a full fit
  // The grid's simulations and the refined fits run on up to this many
  // threads (0: one per core); the result does not depend on it.
  unsigned threads = 1;
  // A restart within the bounds replaces a best fit past them only when its
  // AIC (n_eff ln of the residual ratio) is at most this much higher; a
  // diagnosis sets it to its candidates' gate (-DiagnosisOptions::max_delta_aicc).
  double max_aic_loss = 10.0;
};

struct LugreFit {
  FitResult result;
  std::vector<CurvePoint> steady_points;  // the binned steady sliding points
  CurveFit steady;                        // their Stribeck curve (when it could be fitted)
  bool steady_fitted = false;
  int starts_evaluated = 0;
  int starts_refined = 0;
};

LugreFit fit_lugre(const ModelData& data, const ModelStructure& structure, const std::vector<char>& in_fit,
                   const LugreFitOptions& options = {});

// A fit that ends past the base bounds is often a valley the starts fell
// into, not the data's best: on a soft loop's records the static level runs
// to zero at a Stribeck velocity of nm/s (the shape that mimics the
// unresolved dither's drain, docs/identification.md). fit_lugre refits its
// best fit, when that is past a bound, from its own values with the
// Stribeck curve put back inside the bounds: the static level at 1.1 and 1.5 times the Coulomb level
// (fallback_coulomb where that is past a bound), the Stribeck velocity at a
// fifth of and at the median sliding speed, no negative viscous term, an
// unresolved dither no faster than a tenth of that speed. The four fits,
// whatever their bounds; fit_lugre keeps the best of those within the
// bounds over its best fit past them when the data fit it no worse than
// LugreFitOptions::max_aic_loss, and none past them.
std::vector<FitResult> fits_restarted_inside_bounds(const ModelData& data, const ModelParams& from, double fallback_coulomb,
                                                    const std::vector<char>& in_fit, const LugreFitOptions& options = {});

// Whether a restart replaces the best fit past the bounds: it ends inside
// them and its AIC (n_eff ln of the residual ratio, n_eff the fit past the
// bounds') is at most max_aic_loss higher.
bool restart_replaces(const ModelData& data, const FitResult& past_bounds, const FitResult& restart, double max_aic_loss);

// The base model's values past physical bounds, one line each, every one
// beginning "base model out of bounds": friction coefficients above 2, a
// static level above 5 or below 0.2 times the Coulomb level, negative viscous
// friction worth 5 % of the level at the median speed.
std::vector<std::string> base_out_of_bounds(const ModelData& data, const FitResult& fit);

// Steady sliding samples (past the first fifth of each pass) binned by signed
// velocity: mean of (F - mass a - offset) [/ N when load-scaled], weight
// = samples / variance.
std::vector<CurvePoint> steady_sliding_points(const ModelData& data, const std::vector<char>& in_fit, double mass,
                                              double offset, bool load_scaled);

}  // namespace tribo::analysis
