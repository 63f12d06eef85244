// The reproduction scorecard (issue 14): the dissertation's measurements
// against the simulated instrument on one configuration, row by row:
// observation | dissertation | simulated | relative error.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "tribo/v1/daemon_config.pb.h"

namespace tribo::scorecard {

struct Row {
  std::string group;        // e.g. "Table 5.1"
  std::string observation;  // what is compared
  std::string unit;         // of both values
  double dissertation = 0;
  double simulated = 0;
  double goal = 0;          // |relative error| goal of issue 14; 0: none
  bool points = false;      // compared in percentage points, not relatively

  // (simulated - dissertation) / dissertation, or the difference in points.
  double error() const { return points ? simulated - dissertation : (simulated - dissertation) / dissertation; }
  bool within_goal() const { return goal > 0 && std::abs(error()) <= goal; }
};

// The experiment groups, in the order the scorecard runs them (ScorecardOptions::groups).
inline constexpr std::array<std::string_view, 7> kGroups = {"table_5_1", "fig_4_22", "velocity", "fig_3_12",
                                                            "amontons",  "noise",    "stick_slip"};

struct ScorecardOptions {
  bool quick = false;  // skip the 1000 s experiments (Fig. 4.22's longest rest, Fig. 3.12)
  std::vector<std::string> groups;  // empty: all
  std::uint64_t seed = 1;
};

std::vector<Row> run_scorecard(const v1::DaemonConfig& config, const ScorecardOptions& options);

std::string format_table(const std::vector<Row>& rows);
std::string format_json(const std::vector<Row>& rows, const std::string& config_name);

}  // namespace tribo::scorecard
