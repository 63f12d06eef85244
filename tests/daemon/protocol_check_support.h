// Looking up a protocol check's errors by field, shared by the validator's tests.
#pragma once

#include <string>

#include "daemon/protocol_validator.h"

namespace tribo::testing {

// The first error whose field is `field`, or nullptr.
inline const daemon::ValidationIssue* find(const daemon::ProtocolCheck& c, const std::string& field) {
  for (const auto& e : c.errors) {
    if (e.field == field) return &e;
  }
  return nullptr;
}

// Every error, a line each, for a failing assertion's message.
inline std::string all(const daemon::ProtocolCheck& c) {
  std::string s;
  for (const auto& e : c.errors) s += e.field + ": " + e.message + "\n";
  return s;
}

}  // namespace tribo::testing
