// What the dry run tells a person: the same rule broken in several unrolled
// segments (every pass of a repeat block, or segments alike) said once, with
// the segments and passes listed, e.g.
//
//   segments[1].repeat.segments[1] "scratch" (passes 1-8 of 8): loaded lateral
//   path [-2, 10] µm comes within 0.5 µm of the breakpoint at 0 µm; keep
//   loaded segments on one side of it
//
// The daemon's LoadProtocol error, `tribo check --config` and the Python
// module's sim.check all say it this way.
#pragma once

#include <string>
#include <vector>

#include "daemon/protocol_expansion.h"
#include "daemon/protocol_validator.h"
#include "tribo/v1/api.pb.h"

namespace tribo::daemon {

// Issues that differ only in the segment or pass they name become one, in the
// order of first appearance; its field is the first one's. Issues not about
// one segment are kept as they are (exact repeats dropped).
std::vector<ValidationIssue> group_repeated_issues(const std::vector<ValidationIssue>& issues);

// The issues, grouped, as one message: the first, then " (and K more: b; c;)".
std::string describe_issues(const std::vector<ValidationIssue>& issues);

// The reply to a dry run that passed: name, duration, expected samples and
// every warning, as LoadProtocol answers it.
v1::LoadProtocolReply dry_run_reply(const v1::Protocol& protocol, const ProtocolCheck& check);

// Passes of one segment as a label says them: {"3/8"} -> "(pass 3/8)",
// {"1/8", ..., "8/8"} -> "(passes 1-8 of 8)", {"1/8", "3/8"} -> "(passes 1, 3
// of 8)"; passes of nested blocks ("1/5, 2/6") are listed as they are.
std::string passes_text(const std::vector<std::string>& passes);

}  // namespace tribo::daemon
