#include "analysis/models/evaluated_fit.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace tribo::analysis {

EvaluatedFit evaluate_fit(const ModelData& data, FitResult fit) {
  EvaluatedFit c;
  c.model = simulate(data, fit.params, &c.friction);
  c.fit = std::move(fit);
  return c;
}

ErrorStats error_stats(const std::vector<double>& measured, const std::vector<double>& model, const std::vector<char>& mask) {
  ErrorStats e;
  double sse = 0, ss = 0, sum = 0;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    if (!mask[i]) continue;
    const double err = measured[i] - model[i];
    sse += err * err;
    ss += measured[i] * measured[i];
    sum += measured[i];
    e.max_abs = std::max(e.max_abs, std::fabs(err));
    ++e.n;
  }
  if (e.n == 0) return e;
  const double n = static_cast<double>(e.n);
  e.rms = std::sqrt(sse / n);
  const double var = ss / n - (sum / n) * (sum / n);
  e.nrmse = var > 0 ? e.rms / std::sqrt(var) : 0.0;
  e.relative = ss > 0 ? std::sqrt(sse / ss) : 0.0;
  return e;
}

double rms_over(const std::vector<double>& measured, const std::vector<double>& model, const std::vector<char>& mask) {
  return error_stats(measured, model, mask).rms;
}

}  // namespace tribo::analysis
