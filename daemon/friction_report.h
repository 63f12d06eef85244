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
//   asym_viscous), tilt_offset (tilt_tan), rate_state (rs_a, rs_b, rs_dc and
//   final_model.rate_state_law) and velocity_strengthening
//   (log_velocity_coeff), their log-velocity terms referred to
//   final_model.reference_speed_m_per_s, and load_dependence (load_exponent,
//   referred to final_model.reference_load; it scales a load-scaled model's
//   levels only, as in tribo-fit);
// - ignored, as no force of the contact: offset (a zero of the force
//   reading) and mass (the drive's inertia, fit_mass);
// - refused: frictional_lag (the compensation does not delay the velocity);
//   position_periodic, drift, backlash and a slip trend (functions of where
//   and when the identified record slid, not of the contact); a report
//   without the reference a term needs; forces in a unit other than N.
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
