// A fitted model evaluated on the record: the force it predicts at every
// sample (and its friction part, which the residual signatures read), and
// the error statistics of a model force over a set of samples.
#pragma once

#include <cstddef>
#include <vector>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {

struct EvaluatedFit {
  FitResult fit;
  std::vector<double> model, friction;  // per sample: model force, its friction part
};

EvaluatedFit evaluate_fit(const ModelData& data, FitResult fit);

struct ErrorStats {
  std::size_t n = 0;
  double rms = 0;
  double nrmse = 0;     // rms / standard deviation of the measured force
  double max_abs = 0;
  double relative = 0;  // ||measured - model|| / ||measured|| (the EMPS benchmark's figure)
};

// Over the samples with mask[i] != 0.
ErrorStats error_stats(const std::vector<double>& measured, const std::vector<double>& model,
                       const std::vector<char>& mask);

// error_stats(...).rms.
double rms_over(const std::vector<double>& measured, const std::vector<double>& model, const std::vector<char>& mask);

}  // namespace tribo::analysis
