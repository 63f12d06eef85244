// The scorecard's splits (scorecard/splits.json, scorecard/split.h): which
// rows a split's parameters were fitted on (role "fit") and which they
// predict (role "predicted"), in the rows and in the JSON.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <variant>

#include "scorecard/scorecard.h"
#include "scorecard/split.h"
#include "tests/sim/sim_test_support.h"

namespace tribo::scorecard {
namespace {

const std::string kShipped = std::string(TRIBO_SOURCE_DIR) + "/scorecard/splits.json";

Row make_row(const std::string& source, const std::string& quantity, double load_uN, double velocity_um_s) {
  Row r;
  r.group = source;
  r.quantity = quantity;
  r.observation = quantity;
  r.load_n = load_uN * 1e-6;
  r.velocity_m_per_s = velocity_um_s * 1e-6;
  return r;
}

std::vector<Split> shipped() {
  auto loaded = load_splits(kShipped);
  if (auto* error = std::get_if<std::string>(&loaded)) throw std::runtime_error(*error);
  return std::get<std::vector<Split>>(loaded);
}

// The error of a splits file with this text.
std::string error_of(const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() / "tribo_splits_test.json").string();
  std::ofstream(path) << text;
  auto loaded = load_splits(path);
  std::filesystem::remove(path);
  auto* error = std::get_if<std::string>(&loaded);
  return error ? *error : "";
}

TEST(ScorecardSplit, SelectorsMatchTheFieldsTheyState) {
  const Row fs_9810 = make_row("Table 5.1", "Fs", 9810, 4);
  const Row trend = make_row("Table 5.1", "FsN_trend", NAN, NAN);
  RowSelector table;
  table.source = "Table 5.1";
  EXPECT_TRUE(selects(table, fs_9810));
  EXPECT_TRUE(selects(table, trend));
  RowSelector at_9810 = table;
  at_9810.load_uN = 9810;
  EXPECT_TRUE(selects(at_9810, fs_9810));
  EXPECT_FALSE(selects(at_9810, make_row("Table 5.1", "Fs", 5000, 4)));
  EXPECT_FALSE(selects(at_9810, trend));  // a row without a load is not at 9810 µN
  RowSelector ts_only = table;
  ts_only.quantity = "ts";
  EXPECT_FALSE(selects(ts_only, fs_9810));
  RowSelector slow = table;
  slow.velocity_um_per_s = 0.2;
  EXPECT_TRUE(selects(slow, make_row("Table 5.1", "dl", 5000, 0.2)));
  EXPECT_FALSE(selects(slow, fs_9810));
  EXPECT_FALSE(selects(table, make_row("Fig. 4.22", "spike", 500, 4)));
}

TEST(ScorecardSplit, RowsInTheFitSetAreFitAndAllOthersPredicted) {
  Split split;
  split.name = "test";
  RowSelector at_9810;
  at_9810.source = "Table 5.1";
  at_9810.load_uN = 9810;
  split.fit_rows = {at_9810};
  std::vector<Row> rows = {make_row("Table 5.1", "Fs", 9810, 4), make_row("Table 5.1", "Fs", 5000, 4),
                           make_row("Fig. 4.22", "spike", 500, 4)};
  for (Row& r : rows) {
    r.goal = 0.25;
    r.dissertation = 100;
  }
  rows[0].simulated = 110;  // met
  rows[1].simulated = 150;  // missed
  rows[2].simulated = 120;  // met
  assign_roles(rows, split);
  EXPECT_EQ(rows[0].role, Role::fit);
  EXPECT_EQ(rows[1].role, Role::predicted);
  EXPECT_EQ(rows[2].role, Role::predicted);
  const GoalCounts c = count_goals(rows);
  EXPECT_EQ(c.fit.met, 1);
  EXPECT_EQ(c.fit.with_goal, 1);
  EXPECT_EQ(c.predicted.met, 1);
  EXPECT_EQ(c.predicted.with_goal, 2);
  const auto json = nlohmann::json::parse(format_json(rows, "c.textproto", "test"));
  EXPECT_EQ(json["split"], "test");
  EXPECT_EQ(json["rows"][0]["role"], "fit");
  EXPECT_EQ(json["rows"][1]["role"], "predicted");
  EXPECT_EQ(json["rows"][1]["split"], "test");
  EXPECT_EQ(json["rows"][0]["load_uN"], 9810);
  EXPECT_EQ(json["rows"][0]["velocity_um_per_s"], 4);
  EXPECT_EQ(json["goals_met"]["predicted"]["met"], 1);
  EXPECT_EQ(json["goals_met"]["predicted"]["of"], 2);
  const std::string table = format_table(rows, "test");
  EXPECT_NE(table.find("fit rows 1 of 1, predicted rows 1 of 2"), std::string::npos) << table;
}

TEST(ScorecardSplit, AFileWithAnUnknownOrMissingFieldIsRefusedByName) {
  EXPECT_NE(error_of(R"({"splits": [{"name": "a", "config": "c", "fit_rows": [{"source": "Table 5.1", "lod_uN": 9810}]}]})")
                .find("splits[0].fit_rows[0].lod_uN: unknown field"),
            std::string::npos);
  // Without a source a selector would take every row.
  EXPECT_NE(error_of(R"({"splits": [{"name": "a", "config": "c", "fit_rows": [{"load_uN": 9810}]}]})")
                .find("splits[0].fit_rows[0].source: missing"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"splits": [{"name": "a", "config": "c", "fit_rows": [{"source": "T", "load_uN": -1}]}]})")
                .find("splits[0].fit_rows[0].load_uN: expected a number > 0, got -1"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"splits": [{"name": "a", "config": "c", "fit_rows": [{"source": "T"}]},
                                    {"name": "a", "config": "d", "fit_rows": [{"source": "T"}]}]})")
                .find("splits[1].name: \"a\" is declared twice"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"splits": [{"name": "a", "config": "c"}]})").find("splits[0].fit_rows: missing"),
            std::string::npos);
  EXPECT_EQ(error_of(R"({"calibration": {"rows": [{"source": "Table 3.2"}]},
                        "splits": [{"name": "a", "config": "c", "fit_rows": [{"source": "T"}]}]})"),
            "");
}

// The shipped splits on the default instrument's Table 5.1 rows: fitted at
// 9810 µN, every 9810 µN row and the overshoots are fit and every 5000 µN
// row predicted; fitted at 5000 µN, the reverse.
TEST(ScorecardSplit, TheShippedSplitsMarkTable51ByLoad) {
  const std::vector<Split> splits = shipped();
  ScorecardOptions options;
  options.groups = {"table_5_1"};
  const std::vector<Row> measured = run_scorecard(testing::default_config(), options);
  for (const char* name : {"fit_9810", "fit_5000"}) {
    const Split* split = find_split(splits, name);
    ASSERT_NE(split, nullptr) << name;
    std::vector<Row> rows = measured;
    assign_roles(rows, *split);
    const double fitted_load = std::string(name) == "fit_9810" ? 9810e-6 : 5000e-6;
    int fit = 0, predicted = 0;
    for (const Row& r : rows) {
      if (r.group == "Table 5.1" && std::isfinite(r.load_n)) {
        EXPECT_EQ(r.role, std::abs(r.load_n - fitted_load) < 1e-9 ? Role::fit : Role::predicted)
            << name << ": " << r.observation;
      }
      if (r.group == "Sec. 5.3.1" && r.quantity == "overshoot") {
        EXPECT_EQ(r.role, fitted_load == 9810e-6 ? Role::fit : Role::predicted) << name << ": " << r.observation;
      }
      if (r.group == "Sec. 5.3.1" && r.quantity == "acceleration") {
        EXPECT_EQ(r.role, Role::predicted);
      }
      (r.role == Role::fit ? fit : predicted) += r.goal > 0;
    }
    EXPECT_EQ(fit, 12) << name;  // Fs, ts, dl at the four velocities of one load
    EXPECT_EQ(predicted, 12) << name;
    const auto json = nlohmann::json::parse(format_json(rows, split->config, split->name));
    for (const auto& r : json["rows"]) {
      EXPECT_TRUE(r["role"] == "fit" || r["role"] == "predicted") << r.dump();
      EXPECT_EQ(r["split"], name);
    }
  }
}

// Every selector of every shipped split takes at least one row of the
// scorecard: a misspelt source or quantity would silently turn fit rows
// into predictions.
TEST(ScorecardSplit, EveryShippedSelectorSelectsARow) {
  ScorecardOptions options;
  options.quick = true;
  options.groups = {"table_5_1", "fig_4_22", "velocity", "amontons", "noise"};
  const std::vector<Row> rows = run_scorecard(testing::default_config(), options);
  for (const Split& split : shipped()) {
    for (const RowSelector& s : split.fit_rows) {
      const bool any = std::any_of(rows.begin(), rows.end(), [&](const Row& r) { return selects(s, r); });
      EXPECT_TRUE(any) << split.name << ": source " << s.source << " quantity " << s.quantity << " load "
                       << s.load_uN << " velocity " << s.velocity_um_per_s;
    }
    EXPECT_TRUE(std::filesystem::exists(std::string(TRIBO_SOURCE_DIR) + "/" + split.config)) << split.config;
  }
}

}  // namespace
}  // namespace tribo::scorecard
