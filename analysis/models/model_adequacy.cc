#include "analysis/models/model_adequacy.h"

#include <cmath>

#include <fmt/format.h>

#include "analysis/models/lugre_fit.h"

namespace tribo::analysis {
namespace {

// A normal deviate of 1.96: the interval's half width in standard errors.
constexpr double kInterval95 = 1.96;

std::string negative_viscous(const FitResult& fit) {
  for (const ParamEstimate& e : fit.estimates) {
    if (e.name != "Fv" || e.fixed) continue;
    const double se = std::isfinite(e.std_error) ? e.std_error : 0.0;
    if (e.value + kInterval95 * se < 0) {
      return fmt::format("negative viscous friction: Fv = {:.3g} +- {:.2g} {} (95 % interval below zero)", e.value, se,
                         e.unit);
    }
  }
  return {};
}

}  // namespace

ModelAdequacy judge_model_adequacy(const ModelData& data, const FitResult& final_fit) {
  ModelAdequacy out;
  out.reasons = base_out_of_bounds(data, final_fit);
  if (std::string v = negative_viscous(final_fit); !v.empty()) out.reasons.push_back(std::move(v));
  out.describes_record = out.reasons.empty();
  return out;
}

}  // namespace tribo::analysis
