// Residual signatures: for each effect of the vocabulary, the pattern its
// absence leaves in the residual (measured minus model) of a model that lacks
// it, measured on the fit samples only, with a strength (>= 1: the pattern is
// there, worth fitting the extension), a one-line summary with the numbers,
// initial values for the extension's parameters, and the data for a plot of
// the residual against the regressor that reveals it.
//
// Effects that mimic each other are told apart by what only one of them does:
//   tilt_offset vs direction_asymmetry: a tilt force N tan(theta) is there at
//     rest too (it follows the load during loading holds) and does not flip
//     with direction; an asymmetry acts only in sliding.
//   drift vs dwell_stiction: drift moves the mean force of whole passes and
//     holds with time; dwell stiction is an excess at motion onset over the
//     same pass's sliding level, growing with the preceding dwell.
//   frictional_lag vs presliding_hysteresis: lag acts in sliding while the
//     velocity changes (residual ~ -a dS/dv, away from reversals); presliding
//     hysteresis acts within a few presliding lengths after each reversal.
//   velocity_strengthening vs viscous friction: the base model is already
//     viscous (Fv v); a log-velocity law leaves curvature against ln|v| over
//     at least a decade of speed (or forces the Stribeck term upside down).
//   backlash vs presliding_hysteresis: backlash holds the measured force near
//     zero over a distance after reversals; hysteresis changes its shape only.
#pragma once

#include <cstdint>

#include <algorithm>
#include <string>
#include <vector>

#include "analysis/effects/effect.h"
#include "analysis/models/friction_model.h"

namespace tribo::analysis {

struct SignaturePlot {
  std::string x_label;
  std::string y_label;
  std::vector<double> x, y, y_error;
};

struct Signature {
  Effect effect = Effect::kDrift;
  bool applicable = false;
  double strength = 0;
  double score_t = 0;                   // filled by the diagnosis: score test of the extension
  std::string summary;                  // what was measured, or why not applicable
  std::vector<double> initial_values;   // for effect_parameters(effect), in order
  std::vector<std::string> fixed_parameters;  // held at their initial value: these data cannot determine them
  bool periodic_additive = false;       // position_periodic: which form the phases point to
  SignaturePlot plot;
};

struct SignatureInput {
  const ModelData& data;
  const ModelParams& params;
  const std::vector<double>& model;     // model force, all samples
  const std::vector<double>& friction;  // its friction part (simulate(..., &friction))
  const std::vector<char>& in_fit;
};

// The per-sample quantities every signature reads: the residual, the model's
// steady friction level and presliding length g, and each sample's zone.
// Built once per model and shared read-only by a round's signatures (6 ms
// each on a 200 000-sample record, built once per signature before). It
// refers to the input's arrays: the input must outlive it.
struct SignatureContext {
  explicit SignatureContext(const SignatureInput& input);
  bool sliding(std::size_t i) const { return zone[i] == Zone::kSliding || zone[i] == Zone::kSteady; }
  bool steady(std::size_t i) const { return zone[i] == Zone::kSteady; }
  bool pass_in_fit(const Pass& p) const { return in.in_fit[p.first] && in.in_fit[p.last]; }
  // Level factor of the friction parameters: N for load-scaled models, else 1.
  double level_factor(std::size_t i) const {
    return in.params.structure.load_scaled && s.has_normal() ? std::max(s.normal_force_n[i], 0.0) : 1.0;
  }

  enum class Zone : std::uint8_t { kNone, kHold, kPresliding, kSliding, kSteady };  // one byte a sample
  const SignatureInput& in;
  const MeasuredSeries& s;
  const MotionSegmentation& m;
  double sigma0 = 0, fv = 0;
  std::vector<double> r, level, g;
  std::vector<Zone> zone;
};

Signature compute_signature(Effect effect, const SignatureContext& context);
Signature compute_signature(Effect effect, const SignatureInput& input);

}  // namespace tribo::analysis
