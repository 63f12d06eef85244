// `tribo check --plot`: the planned normal and lateral setpoints of a
// protocol, as the daemon's load function (daemon/load_function.h) will
// command them, drawn to a PNG by /usr/bin/python3 with matplotlib. Begins
// taken from the measured value (first segment, mode changes) are planned
// from the previous setpoint (0 at the start).
#pragma once

#include <string>

#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo::client {

// time_s,segment,segment_name,normal_mode,normal_setpoint,normal_unit,lateral_mode,lateral_setpoint,lateral_unit
// rows (µN / µm), at most max_rows spread evenly over the run plus every
// segment's first tick. Empty and error set if the protocol does not compile.
std::string planned_setpoints_csv(const v1::Protocol& protocol, const v1::DaemonConfig& config,
                                  std::size_t max_rows, std::string& error);

// Writes the plot; false and error set on failure.
bool plot_planned_setpoints(const v1::Protocol& protocol, const v1::DaemonConfig& config, const std::string& png,
                            std::string& error);

}  // namespace tribo::client
