// Bounds that hold for every field of a request, whatever message it is:
// every floating-point number is finite (a NaN compares false with every
// limit, so a range check alone lets it through), and every string has a
// bounded length (a 2 MiB name would pass once and then break every listing
// of the data directory). Walked by reflection, so a field added to the
// schema later is covered without anyone remembering to.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <google/protobuf/message.h>

namespace tribo::daemon {

inline constexpr std::size_t kMaxNameBytes = 256;        // names, keys, short labels
inline constexpr std::size_t kMaxTextBytes = 4096;       // descriptions, notes, reasons, file paths
inline constexpr std::size_t kMaxReportBytes = 1 << 20;  // an identification report (report_json)
inline constexpr std::size_t kMaxMapEntries = 64;        // free-form key=value maps

struct FieldBoundsIssue {
  std::string field;    // path from the message, e.g. "segments[2].normal.end_uN"
  std::string message;  // names the field, the value and the limit
};

// Every issue of message (at most max_issues), field paths prefixed with prefix.
std::vector<FieldBoundsIssue> check_field_bounds(const google::protobuf::Message& message,
                                                 const std::string& prefix = "",
                                                 std::size_t max_issues = 20);

// The limit for a string field of this name: kMaxTextBytes for free text
// (description, note, reason, message) and report_file, kMaxReportBytes for
// report_json (a friction model report, docs/friction_compensation.md),
// kMaxNameBytes otherwise.
std::size_t max_string_bytes(std::string_view field_name);

// The first bytes of text, cut at a UTF-8 boundary, with control characters
// (newlines forge log lines) replaced by '?': for logging what a client sent.
std::string printable_prefix(std::string_view text, std::size_t max_bytes);

}  // namespace tribo::daemon
