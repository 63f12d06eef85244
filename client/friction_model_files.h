// The friction model reports a protocol compensates with
// (docs/friction_compensation.md), read on the client side: the daemon sees
// only their bytes (FrictionCompensation.report_json), never a path of the
// client's file system.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "tribo/v1/protocol.pb.h"

namespace tribo::client {

// Fills report_json of every friction_compensation of the protocol (its own
// and its segments', repeat blocks included) that names a report_file and
// has no report_json yet, the file read relative to protocol_dir unless it is
// absolute. Returns a message naming the field and the file on failure.
std::optional<std::string> read_friction_reports(v1::Protocol& protocol, const std::filesystem::path& protocol_dir);

// `--friction-model REPORT`: the report compensates every displacement
// segment of the run, in place of the protocol's own friction_compensation
// (segments that set theirs keep it). report_path is kept as report_file.
std::optional<std::string> set_friction_model(v1::Protocol& protocol, const std::string& report_path);

}  // namespace tribo::client
