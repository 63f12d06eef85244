// Loading and checking the daemon's config (protobuf text format). Errors name
// the field, the value and the limit.
#pragma once

#include <optional>
#include <string>

#include "tribo/v1/daemon_config.pb.h"

namespace tribo::daemon {

// Parses path into config and validates it; returns the first error or nullopt.
std::optional<std::string> load_daemon_config(const std::string& path, v1::DaemonConfig& config);

std::optional<std::string> validate_daemon_config(const v1::DaemonConfig& config);

// Checks one set of PID gains; `at` prefixes the field names in errors.
std::optional<std::string> validate_pid_gains(const std::string& at, const v1::PidGains& gains);

}  // namespace tribo::daemon
