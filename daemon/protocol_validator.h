// The dry run: checks a protocol against the instrument's limits before
// anything moves, and compiles it into a LoadFunction. Every issue names the
// segment, the field, the value and the limit, in the units of the protocol
// file (µm, µN, s).
#pragma once

#include <string>
#include <vector>

#include "daemon/load_function.h"
#include "tribo/v1/daemon_config.pb.h"
#include "tribo/v1/protocol.pb.h"

namespace tribo::daemon {

struct ValidationIssue {
  std::string field;    // e.g. "segments[2].normal.end_uN"
  std::string message;  // says the value and the limit
};

struct ProtocolCheck {
  std::vector<ValidationIssue> errors;  // empty: the protocol may run
  std::vector<std::string> warnings;
  LoadFunction load_function;           // meaningful only without errors
  double duration_s = 0;

  bool ok() const { return errors.empty(); }
};

ProtocolCheck validate_protocol(const v1::Protocol& protocol, const v1::InstrumentLimits& limits,
                                const v1::ControllerConfig& controller);

}  // namespace tribo::daemon
