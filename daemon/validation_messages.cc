#include "daemon/validation_messages.h"

#include <algorithm>
#include <charconv>
#include <map>
#include <optional>

namespace tribo::daemon {

namespace {

// "3/8" -> {3, 8}; nullopt for anything else (nested passes).
std::optional<std::pair<unsigned, std::string>> simple_pass(const std::string& pass) {
  const auto slash = pass.find('/');
  if (slash == std::string::npos || pass.find(',') != std::string::npos) return std::nullopt;
  unsigned index = 0;
  const char* begin = pass.data();
  const auto [end, error] = std::from_chars(begin, begin + slash, index);
  if (error != std::errc() || end != begin + slash) return std::nullopt;
  return std::pair{index, pass.substr(slash + 1)};
}

// 1, 2, 3, 5 -> "1-3, 5"
std::string ranges(const std::vector<unsigned>& sorted) {
  std::string out;
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j + 1 < sorted.size() && sorted[j + 1] == sorted[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += std::to_string(sorted[i]);
    if (j > i) out += (j == i + 1 ? ", " : "-") + std::to_string(sorted[j]);
    i = j + 1;
  }
  return out;
}

// The rule an issue states, without the segment label it begins with.
std::string rule_of(const ValidationIssue& issue) {
  if (issue.segment.empty()) return issue.message;
  const std::string label = issue.segment + (issue.pass.empty() ? "" : " (pass " + issue.pass + ")") + ": ";
  return issue.message.starts_with(label) ? issue.message.substr(label.size()) : issue.message;
}

// The field below the segment's own path (".lateral"), so that the same rule
// on the same field of different segments groups.
std::string field_in_segment(const ValidationIssue& issue) {
  const std::string path = issue.segment.substr(0, issue.segment.find(' '));
  return issue.field.starts_with(path) ? issue.field.substr(path.size()) : issue.field;
}

struct Group {
  ValidationIssue first;
  std::string rule;
  std::vector<std::string> segments;              // in order of first appearance
  std::map<std::string, std::vector<std::string>> passes;  // per segment
};

}  // namespace

std::string passes_text(const std::vector<std::string>& passes) {
  if (passes.size() == 1) return "(pass " + passes.front() + ")";
  std::vector<unsigned> indices;
  std::string count;
  for (const std::string& p : passes) {
    const auto simple = simple_pass(p);
    if (!simple || (!count.empty() && simple->second != count)) {
      std::string listed;
      for (const std::string& q : passes) listed += (listed.empty() ? "" : " and ") + q;
      return "(passes " + listed + ")";
    }
    count = simple->second;
    indices.push_back(simple->first);
  }
  std::sort(indices.begin(), indices.end());
  return "(passes " + ranges(indices) + " of " + count + ")";
}

std::vector<ValidationIssue> group_repeated_issues(const std::vector<ValidationIssue>& issues) {
  std::vector<Group> groups;
  std::map<std::string, std::size_t> index;
  for (const ValidationIssue& issue : issues) {
    const std::string rule = rule_of(issue);
    const std::string key = issue.segment.empty() ? "\x01" + issue.field + "\x1f" + issue.message
                                                  : field_in_segment(issue) + "\x1f" + rule;
    auto [it, added] = index.emplace(key, groups.size());
    if (added) groups.push_back({issue, rule, {}, {}});
    if (issue.segment.empty()) continue;
    Group& g = groups[it->second];
    if (std::find(g.segments.begin(), g.segments.end(), issue.segment) == g.segments.end()) {
      g.segments.push_back(issue.segment);
    }
    if (!issue.pass.empty()) g.passes[issue.segment].push_back(issue.pass);
  }
  std::vector<ValidationIssue> out;
  for (const Group& g : groups) {
    if (g.first.segment.empty()) {
      out.push_back(g.first);
      continue;
    }
    std::string subjects;
    for (const std::string& segment : g.segments) {
      const auto found = g.passes.find(segment);
      const std::vector<std::string> passes = found == g.passes.end() ? std::vector<std::string>{} : found->second;
      subjects += (subjects.empty() ? "" : ", ") + segment + (passes.empty() ? "" : " " + passes_text(passes));
    }
    ValidationIssue grouped = g.first;
    grouped.message = subjects + ": " + g.rule;
    if (g.segments.size() > 1 || (g.passes.contains(g.first.segment) && g.passes.at(g.first.segment).size() > 1)) {
      grouped.pass.clear();
    }
    out.push_back(std::move(grouped));
  }
  return out;
}

v1::LoadProtocolReply dry_run_reply(const v1::Protocol& protocol, const ProtocolCheck& check) {
  v1::LoadProtocolReply reply;
  reply.set_protocol_name(protocol.name());
  reply.set_duration_s(check.duration_s);
  reply.set_expected_samples(check.load_function.expected_samples());
  for (const std::string& w : check.warnings) reply.add_warnings(w);
  return reply;
}

std::string describe_issues(const std::vector<ValidationIssue>& issues) {
  const std::vector<ValidationIssue> grouped = group_repeated_issues(issues);
  if (grouped.empty()) return "";
  std::string message = grouped.front().message;
  if (grouped.size() > 1) {
    message += " (and " + std::to_string(grouped.size() - 1) + " more:";
    for (std::size_t i = 1; i < grouped.size(); ++i) message += " " + grouped[i].message + ";";
    message += ")";
  }
  return message;
}

}  // namespace tribo::daemon
