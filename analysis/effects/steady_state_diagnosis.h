// The effect report for steady-state friction points (`tribo-fit
// stribeck --diagnose`): points (velocity, force[, load]) measured on
// plateaus, as a drive's or a tribometer's steady-state curve comes, not a
// time series. The same decision as the time-series diagnosis, on held-out
// points: a base model is chosen, then each candidate effect is added only if
// it lowers the held-out error and its parameters are physical.
//
// Models (all linear in their levels given the nonlinear scales):
//   F(v) = sgn(v) L(N) [Fc_d + (Fs_d - Fc_d) exp(-(|v|/vs)^D) + k ln(|v|/v_ref)]
//          + Fv_d v + offset
// d is the direction (one set of levels unless direction_asymmetry is in the
// model, then one per direction and no offset, which the two levels absorb);
// L(N) = (N/N_ref)^p with p = 1 (friction proportional to load) unless
// load_dependence frees p; L = 1 without a load column.
//   base: coulomb_viscous (no Stribeck term) or lugre_steady (with it), the
//         one with the lower held-out error, the simpler unless the richer
//         lowers it by the acceptance margin;
//   candidates: direction_asymmetry, velocity_strengthening (k > 0; k < 0 is
//         velocity weakening, the Stribeck term's business), load_dependence.
// Held-out error: leave-one-out over the points up to 200 points, else 10
// folds dealt round-robin in velocity order; every fold refits the scales.
#pragma once

#include <string>
#include <vector>

namespace tribo::analysis {

struct SteadyPoint {
  double velocity_m_per_s = 0;  // signed
  double force_n = 0;           // friction force, signed with the motion
  double load_n = 0;            // normal load; only read when the diagnosis has loads
  double weight = 1;
};

struct SteadyParameter {
  std::string name;
  double value = 0;
  double std_error = 0;  // conditional on the nonlinear scales (vs, p)
  std::string unit;
};

struct SteadyModelFit {
  std::string name;                       // "coulomb_viscous", "lugre_steady" + effects
  std::vector<SteadyParameter> parameters;
  double fit_rms_n = 0;                   // weighted RMS residual on all points
  double held_out_rms_n = 0;              // weighted RMS of the held-out predictions
};

struct SteadyCandidate {
  std::string effect;
  SteadyModelFit fit;
  double change = 0;      // held-out RMS relative to the model it extends (-0.2 = 20 % lower)
  bool accepted = false;
  std::string reason;
};

struct SteadyDiagnosis {
  std::size_t points = 0;
  bool has_load = false;
  std::string held_out_scheme;              // "leave-one-out" or "10-fold"
  std::vector<SteadyModelFit> base_evidence;  // both base models
  SteadyModelFit base;
  std::vector<std::vector<SteadyCandidate>> rounds;
  std::vector<std::string> accepted;        // in the order accepted
  SteadyModelFit final_model;
  std::vector<std::string> warnings;
};

struct SteadyOptions {
  double stribeck_exponent = 1;
  double acceptance_margin = 0.05;  // a candidate must lower the held-out RMS by this fraction
  bool has_load = false;
};

// Throws std::invalid_argument for too few or non-finite points.
SteadyDiagnosis diagnose_steady_state(const std::vector<SteadyPoint>& points, const SteadyOptions& options);

std::string steady_diagnosis_json(const SteadyDiagnosis& d);
std::string steady_diagnosis_text(const SteadyDiagnosis& d);

}  // namespace tribo::analysis
