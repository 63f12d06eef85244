// printf-style report messages whose formats name their units (analysis
// reasons, verdicts and warnings), without a fixed buffer.
#pragma once

#include <string>

#include <fmt/printf.h>

namespace tribo::analysis {

inline std::string fmt(const char* format, double a, double b = 0, double c = 0, double d = 0) {
  return fmt::sprintf(format, a, b, c, d);
}

}  // namespace tribo::analysis
