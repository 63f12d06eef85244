// How strong an effect the diagnosis did not accept would have to be for this
// record to reveal it ("where a protocol cannot reveal an effect at
// a given strength and noise, the report says so per effect"). The question is
// asked of the record, not of the effect: the same protocol at the same noise
// gives the same answer whether the effect is there or not.
//
// Method (a linearised power calculation against the diagnosis's own gates):
// the effect is switched on in the final model at strength s along one axis
// (its strength parameter, the others at their neutral values); the change of
// the model force, minus what the model's free parameters can absorb (its
// least-squares projection onto their Jacobian, as a refit would), is the
// effect's visible part r(s). Added to a record whose residual RMS is sigma,
// it would be accepted when
//   held-out gain   1 - sigma_h / sqrt(sigma_h^2 + mean_h r^2) >= min_heldout_gain
//   AICc            n ln(1 + mean_f r^2 / sigma_f^2) >= 2 k_effect - max_delta_aicc
//   strength        n_eff mean_f r^2 / sigma_f^2 >= min_strength_z^2
// (h: held-out samples, f: fit samples; the last is the strength's t statistic
// with the fit's autocorrelation-inflated errors, for a strength alone: the
// effect's other parameters can only widen its error), and when the
// candidate passes the screening before it is fitted, by its score test:
//   score t         sum_f d r / (sigma_f |d|) sqrt(n_eff / n) >= min_score_t
// with d the change before the projection (the score test regresses the
// present residual, which holds r only, on the extension's own sensitivity):
// an effect the base model can largely mimic leaves a small r along d, and
// is screened out at strengths where the fit gates alone would pass it (the
// independent generator's velocity strengthening: score t 1.4-2.0 at a
// strength the fit gates put above the minimum). The minimum detectable strength is
// the s where all hold with the detection probability asked for, found by
// secant steps on s (r grows as s for a linear effect; nonlinear ones take a
// few more steps). The two t statistics (score t, strength) scatter about
// their expected values with unit standard deviation, so where the expected
// t only equals its threshold the effect is found one time in two; their
// expected values must exceed the thresholds by the normal quantile of the
// detection probability (1.28 for 90 %: the usual minimum detectable effect
// of a power analysis). The held-out gain and the AICc of a large record
// scatter little and are taken at their expected values. The block-agreement
// gate and the signature's own test (the screening's other way in) are not
// modelled.
#pragma once

#include <limits>

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>

#include "analysis/effects/effect.h"
#include "analysis/models/friction_model.h"
#include "analysis/models/model_fit.h"

namespace tribo::analysis {

struct DetectableStrength {
  std::string parameter;    // the extension's parameter along which the strength is set
  std::string unit;
  double value = 0;         // minimum detectable strength; +inf: none up to searched_up_to
  double searched_up_to = 0;
  std::string axis;         // how the strength is set, in words
  double detection_probability = 0;  // with which the gates pass at value
  // value was raised to what the candidate's own fitted standard error needs
  // (raise_to_fitted_error).
  bool from_fitted_error = false;
  // Injection and recovery (diagnosis.cc): the strength injected into the
  // record (the figure before the check) and the share of it a refit found;
  // NaN when not checked. Below 1 the figure was divided by the share
  // (from_injection), or set to +inf below a tenth.
  double injected_strength = std::numeric_limits<double>::quiet_NaN();
  double recovered_share = std::numeric_limits<double>::quiet_NaN();
  bool from_injection = false;
  // Not empty: no figure is given (value +inf), and why (diagnosis.cc).
  std::string withheld;
  // Rediagnosis (diagnosis.cc): the strengths at which the effect was
  // injected into the record and the record diagnosed again for it (the
  // final model refitted without it, then the candidate's screening, fit and
  // gates), in order; the figure is the first found. Empty: not checked.
  std::vector<double> rediagnosed_at;
  bool from_rediagnosis = false;  // the figure was raised (or, none found, set to +inf) by it
};

struct DetectabilityCriteria {
  double min_heldout_gain = 0.02;
  double max_delta_aicc = -10.0;
  double min_strength_z = 3.0;
  double min_score_t = 2.0;  // the screening's score test (DiagnosisOptions: score_t_threshold x min_signature_strength)
  double detection_probability = 0.9;
};

// z with P(N(0, 1) < z) = p, for p in (0, 1).
double normal_quantile(double p);

// Where the candidate was fitted in the last round (against the final model:
// an earlier round's model lacked an effect accepted since, and its larger
// residual would inflate the error), its fit measured the
// strength's standard error on this record, with whatever the nonlinear base
// refit absorbs (which the linearised figure underestimates: the
// independent generator's velocity strengthening at three times its default,
// figures of 0.0006-0.001 against fitted errors of 0.0011-0.0016). The
// strength gate then needs at least (min_strength_z + margin) times that
// error: figure raised to it when lower. Only for effects whose force is
// linear in their strength (dwell_dFs, log_velocity_coeff, load_exponent,
// asym_levels, tilt_tan), whose error does not depend on the strength fitted,
// and for rate_state (along rs_a), whose error grows with the strength
// fitted: there the raised figure is still a lower bound, but the linearised
// one alone was far below it (the independent generator's rate-and-state
// files with speed steps: figures of 0.0008 against fitted errors of
// 0.0023-0.0039 and an injected a of 0.004-0.006, refused in all ten);
// trial_parameters: the effect's parameters from its last trial fit.
void raise_to_fitted_error(DetectableStrength& figure, Effect effect, const std::vector<ParamEstimate>& trial_parameters,
                           const DetectabilityCriteria& criteria);

// The effects whose force is linear in their strength (dwell_dFs,
// log_velocity_coeff, load_exponent, asym_levels, tilt_tan): their fitted
// error does not depend on the strength fitted.
bool strength_is_linear(Effect effect);

// The model with the effect added at strength s along its axis (the
// minimum detectable strength's axis; DetectableStrength::axis in words).
ModelParams with_strength(const ModelParams& current, Effect effect, const ModelData& data, double s);

// The rows and the noise a visible part is judged on, shared by the minimum
// detectable strength and the confusion check (analysis/effects/confusion.h):
// a subsample of the fit and held-out rows (at most 20 000 of each), the
// final model's residual RMS on each, and the final fit's effective sample
// count (lag-1 autocorrelation).
struct VisibleRows {
  std::vector<std::size_t> fit, heldout;
  std::size_t n_fit = 0;  // fit rows before subsampling
  double sigma_fit = 0, sigma_heldout = 0;
  double n_effective = 0;
};

VisibleRows visible_rows(const ModelData& data, const FitResult& current, const std::vector<double>& current_model,
                         const std::vector<char>& in_fit, const std::vector<char>& heldout);

// The strength gate's statistic for a visible part r on rows.fit:
// sqrt(n_eff mean r^2) / sigma_fit, the t a strength alone would have with
// the fit's autocorrelation-inflated errors (min_strength_z's units).
double visible_strength_z(const Eigen::VectorXd& r_fit, const VisibleRows& rows);

// The free parameters' columns of p (for model_jacobian).
std::vector<int> free_columns(const ModelParams& p);

// What every effect's question shares: the final model's Jacobian on a
// subsample of the fit and held-out rows, factorised once.
class DetectabilityBasis {
 public:
  DetectabilityBasis(const ModelData& data, const FitResult& current, const std::vector<double>& current_model,
                     const std::vector<char>& in_fit, const std::vector<char>& heldout);

  // nullopt for effects whose strength is not one axis (position-periodic
  // friction: amplitude and wavelength; presliding hysteresis: a ratio whose
  // neutral value is the limit of its range) or without fit/held-out rows.
  std::optional<DetectableStrength> minimum_detectable_strength(Effect effect, const DetectabilityCriteria& criteria) const;

 private:
  // For the effect at strength s: mean r^2 over the fit and held-out
  // subsamples, and the score test's t on the fit subsample.
  struct Visible {
    double power_fit = 0, power_heldout = 0, score_t = 0;
  };
  Visible visible(const ModelParams& extended, Effect effect, double s) const;

  const ModelData& data_;
  const FitResult& current_;
  const std::vector<double>& current_model_;
  VisibleRows rows_;
  Eigen::MatrixXd jacobian_fit_, jacobian_heldout_;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_fit_;
};

}  // namespace tribo::analysis
