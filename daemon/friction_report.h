// Reads the identified friction model the compensation uses from the report
// `tribo-fit diagnose --json` writes (docs/tribo_fit.md): its final_model
// (effects, parameters, rate_state_law) and the base model's structure
// (base_model.load_scaled, base_model.stribeck_exponent), the report's text
// taken as it is. A model the compensation cannot evaluate is refused with
// the reason, naming the effect or parameter:
//
// - evaluated: the LuGre base (mu_c/Fc, mu_s/Fs, vs, sigma0, sigma1, Fv),
//   presliding_hysteresis (breakaway_ratio), dwell_stiction (dwell_dFs,
//   dwell_time, dwell_memory), direction_asymmetry (asym_levels,
//   asym_viscous) and tilt_offset (tilt_tan);
// - ignored, as no force of the contact: offset (a zero of the force
//   reading) and mass (the drive's inertia, fit_mass);
// - refused: rate_state and velocity_strengthening (their log-velocity terms
//   are referred to the identified record's median sliding speed, which the
//   report does not state), frictional_lag, load_dependence (referred to the
//   record's median load, not stated either), position_periodic, drift,
//   backlash and a slip trend (functions of where and when the identified
//   record slid, not of the contact), and forces in a unit other than N.
#pragma once

#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "daemon/identified_friction.h"

namespace tribo::daemon {

struct ReportParameter {
  std::string name;
  double value = 0;
  std::string unit;
};

struct FrictionReport {
  IdentifiedFriction model;
  std::string sha256;                    // of the report's bytes, lower-case hex
  std::string contact;                   // "lugre" and the final model's effects, e.g. "lugre + tilt_offset"
  std::vector<ReportParameter> parameters;  // final_model.parameters, as the report gives them
  std::string report_file;               // as the protocol named it (the validator sets it)
};

// The report, or why the compensation cannot use it.
std::variant<FrictionReport, std::string> read_friction_report(std::string_view report_json);

// SHA-256 of bytes, lower-case hex (OpenSSL).
std::string sha256_hex(std::string_view bytes);

}  // namespace tribo::daemon
