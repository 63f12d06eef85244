// Shared helpers for the analysis tests: where the measured-data copies are,
// and a diagnosis of a synthetic or measured series in one call.
#pragma once

#include <algorithm>
#include <string>

#include "analysis/diagnosis.h"
#include "analysis/input/series_input.h"

namespace tribo::testing {

inline std::string measured_data(const std::string& file) {
  return std::string(TRIBO_SOURCE_DIR) + "/tests/data/measured/" + file;
}

inline bool accepted(const analysis::Diagnosis& d, analysis::Effect e) {
  return std::any_of(d.accepted.begin(), d.accepted.end(), [e](const auto& a) { return a.effect == e; });
}

inline std::string accepted_names(const analysis::Diagnosis& d) {
  std::string out;
  for (const auto& a : d.accepted) out += std::string(analysis::effect_name(a.effect)) + " ";
  if (out.empty()) out = "(none)";
  for (const auto& r : d.adequacy.reasons) out += "; not describing the record: " + r;
  return out;
}

inline analysis::MeasuredSeries read_or_throw(const std::string& path, const analysis::ColumnMapping& columns) {
  std::string error;
  auto s = analysis::read_csv_series(path, columns, error);
  if (!s) throw std::runtime_error(error);
  return *s;
}

}  // namespace tribo::testing
