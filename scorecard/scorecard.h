// The reproduction scorecard: the dissertation's measurements against the
// simulated instrument on one configuration, row by row: observation |
// dissertation | simulated | relative error, and each row's role in the
// configuration's fit (scorecard/split.h).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "tribo/v1/daemon_config.pb.h"

namespace tribo::scorecard {

// A row's part in the fit of the configuration scored: its measurement was
// one the parameters were fitted (or set) on, or it is a prediction.
enum class Role { unassigned, fit, predicted };

struct Row {
  std::string group;        // the dissertation's source, e.g. "Table 5.1"
  std::string observation;  // what is compared
  std::string unit;         // of both values
  double dissertation = 0;
  double simulated = 0;
  double goal = 0;          // |relative error| goal; 0: none
  bool points = false;      // compared in percentage points, not relatively
  // What the row measures and where, for selecting rows (scorecard/splits.json):
  // e.g. quantity "Fs" at 9810 µN and 4 µm/s; NaN where the row has no load or velocity.
  std::string quantity;
  double load_n = std::numeric_limits<double>::quiet_NaN();
  double velocity_m_per_s = std::numeric_limits<double>::quiet_NaN();
  Role role = Role::unassigned;

  // (simulated - dissertation) / dissertation, or the difference in points.
  double error() const { return points ? simulated - dissertation : (simulated - dissertation) / dissertation; }
  bool within_goal() const { return goal > 0 && std::abs(error()) <= goal; }
};

// The experiment groups, in the order the scorecard runs them (ScorecardOptions::groups).
inline constexpr std::array<std::string_view, 8> kGroups = {"table_5_1", "fig_4_22", "velocity", "fig_3_12",
                                                            "amontons",  "noise",    "stick_slip", "after_passes"};

struct ScorecardOptions {
  bool quick = false;  // skip the 1000 s experiments (Fig. 4.22's longest rest, Fig. 3.12)
  std::vector<std::string> groups;  // empty: all
  std::uint64_t seed = 1;
};

std::vector<Row> run_scorecard(const v1::DaemonConfig& config, const ScorecardOptions& options);

// Goals met, counted separately over the fit rows, the predicted rows and
// the rows without a role.
struct GoalCount {
  int met = 0, with_goal = 0;
};
struct GoalCounts {
  GoalCount fit, predicted, unassigned;
};
GoalCounts count_goals(const std::vector<Row>& rows);

std::string role_name(Role role);  // "fit", "predicted", "" (unassigned)

// split: the name of the split whose roles the rows carry ("" if none).
std::string format_table(const std::vector<Row>& rows, const std::string& split = "");
std::string format_json(const std::vector<Row>& rows, const std::string& config_name, const std::string& split = "");

}  // namespace tribo::scorecard
