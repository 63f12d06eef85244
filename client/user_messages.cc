#include "client/user_messages.h"

#include <map>
#include <regex>

#include "daemon/validation_messages.h"

namespace tribo::client {

std::vector<std::string> collapse_repeated(const std::vector<std::string>& messages) {
  static const std::regex pass(R"(\(pass (\d+)/(\d+)\))");
  struct Group {
    std::string text;  // with a placeholder for the passes
    std::string total;
    std::vector<std::string> passes;
  };
  std::vector<Group> groups;
  std::map<std::string, std::size_t> index;
  for (const std::string& m : messages) {
    std::smatch match;
    if (!std::regex_search(m, match, pass)) {
      index.emplace(m, groups.size());
      groups.push_back({m, "", {}});
      continue;
    }
    const std::string key = std::string(match.prefix()) + "\x01" + std::string(match.suffix()) + "/" + match[2].str();
    auto [it, added] = index.emplace(key, groups.size());
    if (added) groups.push_back({std::string(match.prefix()) + "\x01" + std::string(match.suffix()), match[2].str(), {}});
    groups[it->second].passes.push_back(match[1].str());
  }
  std::vector<std::string> out;
  for (const Group& g : groups) {
    const auto at = g.text.find('\x01');
    if (at == std::string::npos) {
      out.push_back(g.text);
      continue;
    }
    std::vector<std::string> passes;
    for (const std::string& p : g.passes) passes.push_back(p + "/" + g.total);
    out.push_back(g.text.substr(0, at) + daemon::passes_text(passes) + g.text.substr(at + 1));
  }
  return out;
}

std::string explain_missing_duration(const std::string& message) {
  static const std::regex zero(R"(duration_s = 0 s must be in \(0,)");
  if (!std::regex_search(message, zero)) return message;
  return std::regex_replace(message, zero,
                            "no duration_s and no lateral.speed_um_per_s given (a segment needs its duration, or a "
                            "speed for a lateral ramp): duration_s = 0 s must be in (0,",
                            std::regex_constants::format_first_only);
}

std::string with_syntax_hint(const std::string& error) {
  std::string hint;
  if (error.find("Expected identifier, got: ") != std::string::npos &&
      error.find_last_not_of(' ') == error.find("got:") + 3) {
    hint = "the file ended inside a block: a closing '}' is missing (check that every '{' is closed)";
  } else if (error.find("Expected \"}\"") != std::string::npos || error.find("Expected \"{\"") != std::string::npos) {
    hint = "a block's braces do not match: every `name {` needs its `}`";
  } else if (error.find("has no field named") != std::string::npos) {
    hint = "a misspelt field name (the protocol reference lists them: docs/protocols.md)";
  } else if (error.find("Expected") != std::string::npos || error.find("Unknown enumeration value") != std::string::npos) {
    hint = "protocol files are protobuf text format: `field: value`, blocks `name { ... }` (docs/protocols.md)";
  }
  return hint.empty() ? error : error + "\n  hint: " + hint;
}

}  // namespace tribo::client
