// Unrolls a protocol's repeat blocks into the flat list of segments that will
// run: per-pass values substituted, odd passes mirrored when a block
// alternates direction. Each segment keeps the path of its definition in the
// file (for error messages) and the pass it belongs to.
#pragma once

#include <string>
#include <vector>

#include "tribo/v1/protocol.pb.h"

namespace tribo::daemon {

struct ValidationIssue {
  std::string field;    // e.g. "segments[2].normal.end_uN"
  std::string message;  // names the segment, the value and the limit
  // When the message is about one unrolled segment it begins with that
  // segment's label and ": "; the label's parts (ExpandedSegment), so that
  // the same rule broken in several segments or passes can be said once
  // (daemon/validation_messages.h). Empty otherwise.
  std::string segment;  // path and name: segments[2].repeat.segments[0] "scratch"
  std::string pass;     // "3/8", nested "1/5, 2/6"; empty outside repeat blocks
};

struct ExpandedSegment {
  v1::Segment segment;  // no repeat; per_pass already applied
  std::string path;     // "segments[2].repeat.segments[0]"
  std::string label;    // path, name and pass: segments[2].repeat.segments[0] "scratch" (pass 3/8)
  std::string name;     // name with the pass, for the run's segment table
  std::string subject;  // the label without the pass: segments[2].repeat.segments[0] "scratch"
  std::string pass;     // "3/8", nested "1/5, 2/6"; empty outside repeat blocks
};

struct Expansion {
  std::vector<ExpandedSegment> segments;
  std::vector<ValidationIssue> errors;
};

// At most max_segments segments after unrolling (more is an error).
Expansion expand_protocol(const v1::Protocol& protocol, std::size_t max_segments);

}  // namespace tribo::daemon
