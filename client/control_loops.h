// The controller's loops as users name them (tribo gains/set-gains), the
// units of their PID gains, and the PidGains fields a user may set. The
// loops' output is a drive force in N; the error's unit follows the loop
// (m for the displacement loops, N for the force loops), so kp is N/m or
// N/N, ki N/(m s) or 1/s, kd N s/m or s.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "tribo/v1/api.pb.h"

namespace tribo::client {

// "lateral-displacement", "lateral-force", "normal-force", "normal-displacement".
std::string loop_name(v1::ControlLoop loop);
// The short name, or the enum name (LOOP_LATERAL_FORCE), case-insensitive.
std::optional<v1::ControlLoop> parse_loop(const std::string& text);
// The short names, comma-separated (for messages and --help).
std::string loop_names();

// The settable numeric PidGains fields, in proto order (kp, ki, kd, ...).
std::vector<std::string> gain_fields();
// The unit of a PidGains field of this loop ("N/m", "1/s", "" if dimensionless).
std::string gain_unit(v1::ControlLoop loop, const std::string& field);
// Sets a numeric PidGains field by name; false if there is no such field.
bool set_gain_field(v1::PidGains& gains, const std::string& field, double value);

// The gains as aligned "name value unit" lines, each indented by `indent`.
std::string gains_text(v1::ControlLoop loop, const v1::PidGains& gains, const std::string& indent);

}  // namespace tribo::client
