// What tribo tells a person when something is wrong: the same warning repeated
// for every pass of a repeat block said once with its passes, and protobuf's
// terse text-format syntax errors with a hint.
#pragma once

#include <string>
#include <vector>

namespace tribo::client {

// Messages that differ only in "(pass N/M)" become one, "(passes 1-3 of M)"
// (daemon/validation_messages.h says errors the same way); the order of
// first appearance is kept. For the daemon's warnings.
std::vector<std::string> collapse_repeated(const std::vector<std::string>& messages);

// The daemon's message for a segment without a duration, said as what the
// user left out: neither duration_s nor lateral.speed_um_per_s.
std::string explain_missing_duration(const std::string& message);

// A protobuf text-format parse error with a hint at its usual cause.
std::string with_syntax_hint(const std::string& error);

}  // namespace tribo::client
