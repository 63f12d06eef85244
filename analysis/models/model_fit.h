// Simulation-error fit of the friction model: the model is driven by the
// measured motion over the whole record, and the residual (measured minus
// model force) is minimised over the fit samples only (held-out samples still
// drive the simulation, since the motion is an input, but never enter the
// objective). Eigen's Levenberg-Marquardt on the normalised parameters, with
// an exact Jacobian from forward-mode automatic differentiation.
//
// Uncertainties: covariance s^2 (J^T J)^-1 scaled by n / n_eff, where n_eff
// accounts for the residual's lag-1 autocorrelation (a structured residual
// carries far less information than its sample count suggests). A parameter
// whose normalised standard error exceeds one (a factor e for log
// parameters, its own scale for signed ones) is reported as not determined.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "analysis/models/friction_model.h"

namespace tribo::analysis {

struct FitOptions {
  int max_iterations = 60;       // Jacobian evaluations
  double tolerance = 1e-6;       // relative change of cost and parameters
};

struct ParamEstimate {
  std::string name;
  std::string unit;
  double value = 0;
  double std_error = 0;          // NaN when it cannot be computed
  bool fixed = false;
  bool determined = true;
  std::optional<Effect> effect;
  // The part of std_error from the motion model (DiagnosisOptions::
  // alternative_motions): NaN when not assessed.
  double motion_systematic = std::numeric_limits<double>::quiet_NaN();
};

struct FitResult {
  ModelParams params;
  std::vector<ParamEstimate> estimates;
  double rss = 0;                // over the fit samples
  std::size_t n = 0;             // fit samples
  double n_effective = 0;
  std::size_t k = 0;             // free parameters
  double aicc = 0;               // with n_effective
  int iterations = 0;
  bool converged = false;
  std::vector<std::string> warnings;
  // Covariance of the free parameters' values (the errors of estimates), for
  // joint tests; covariance_row[k] is spec k's row, -1 when fixed.
  Eigen::MatrixXd covariance;
  std::vector<int> covariance_row;
  // Refitted on each defensible alternative motion estimate, each estimate's
  // shift (refit - fit, by estimates index): the motion-model systematic
  // error as a direction. The covariance above stays the statistical one.
  std::vector<std::vector<double>> motion_shifts;
};

// in_fit[i] != 0 marks the samples of the objective.
FitResult fit_model(const ModelData& data, const ModelParams& initial, const std::vector<char>& in_fit,
                    const FitOptions& options = {});

// The estimates of one extension's parameters, in the fit's order.
std::vector<ParamEstimate> parameters_of(const FitResult& fit, Effect effect);

// d model / d theta for the given parameter columns at the given rows (time
// order), by forward-mode autodiff; model (optional) receives the model force
// at every sample.
Eigen::MatrixXd model_jacobian(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                               const std::vector<int>& columns, const std::vector<std::size_t>& rows,
                               std::vector<double>* model = nullptr);

// model_jacobian into out (rows.size() x columns.size()), each entry times
// sign; rows strictly increasing. No per-sample array of dual numbers.
void model_jacobian_into(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                         const std::vector<int>& columns, const std::vector<std::size_t>& rows, double sign,
                         Eigen::Ref<Eigen::MatrixXd> out, std::vector<double>* model = nullptr);

// The model work done so far by the process: every evaluation of a fit's
// model with its Jacobian adds its rows times columns (the fits' cost, on any
// thread; PhaseTimings, analysis/report/phase_timings.h, reports it).
std::uint64_t model_work_done();

// Sum of squared residuals of params over the marked samples (no fitting).
double residual_sum_of_squares(const ModelData& data, const ModelParams& params, const std::vector<char>& in_fit);

// Effective sample count of a residual sequence (lag-1 autocorrelation).
double effective_sample_count(const std::vector<double>& residual);
double effective_sample_count(const double* residual, std::size_t n);

// AICc from the fit's RSS, n, n_eff and k.
double aicc(double rss, std::size_t n, double n_effective, std::size_t k);

}  // namespace tribo::analysis
