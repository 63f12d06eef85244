// tribo-scorecard: runs the dissertation's experiments on a configuration of
// the simulated instrument and prints observation | dissertation | simulated
// | error | goal | role (docs/simulated_instrument.md).
//
//   tribo-scorecard [--config FILE] [--split NAME] [--splits FILE] [--quick] [--group NAME]... [--seed N] [--json]
//
// --split NAME marks each row fit or predicted as the split declares
// (scorecard/splits.json) and, without --config, scores the split's own
// config. Without either, the default config is scored as the split
// "default" (how it was fitted); with --config alone, rows carry no role.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>

#include "daemon/daemon_config.h"
#include "scorecard/scorecard.h"
#include "scorecard/split.h"

int main(int argc, char** argv) {
  CLI::App app{"Reproduction scorecard: the dissertation's measurements vs the simulated instrument"};
  std::string config_path = TRIBO_SOURCE_DIR "/config/tribod.textproto";
  std::string splits_path = TRIBO_SOURCE_DIR "/scorecard/splits.json";
  std::string split_name;
  tribo::scorecard::ScorecardOptions options;
  bool json = false;
  auto* config_option =
      app.add_option("--config", config_path, "daemon config (its sim and controller sections are used)");
  auto* split_option =
      app.add_option("--split", split_name, "mark rows fit/predicted as this split declares; without --config, score its config");
  app.add_option("--splits", splits_path, "the split declarations (default: scorecard/splits.json)");
  app.add_flag("--quick", options.quick, "skip the 1000 s experiments (Fig. 4.22's longest rest, Fig. 3.12)");
  app.add_option("--group", options.groups,
                 "table_5_1, fig_4_22, velocity, fig_3_12, amontons, noise, stick_slip, after_passes (default: all)")
      ->check(CLI::IsMember(std::vector<std::string>(tribo::scorecard::kGroups.begin(), tribo::scorecard::kGroups.end())));
  app.add_option("--seed", options.seed, "seed of the simulated instrument");
  app.add_flag("--json", json, "print JSON instead of a table");
  CLI11_PARSE(app, argc, argv);

  const tribo::scorecard::Split* split = nullptr;
  std::vector<tribo::scorecard::Split> splits;
  if (split_option->count() > 0 || config_option->count() == 0) {
    if (split_option->count() == 0) split_name = "default";
    auto loaded = tribo::scorecard::load_splits(splits_path);
    if (auto* error = std::get_if<std::string>(&loaded)) {
      std::fprintf(stderr, "tribo-scorecard: %s\n", error->c_str());
      return 2;
    }
    splits = std::get<std::vector<tribo::scorecard::Split>>(std::move(loaded));
    split = tribo::scorecard::find_split(splits, split_name);
    if (!split) {
      std::fprintf(stderr, "tribo-scorecard: --split %s: no such split in %s\n", split_name.c_str(), splits_path.c_str());
      return 2;
    }
    if (config_option->count() == 0) config_path = TRIBO_SOURCE_DIR "/" + split->config;
  }

  tribo::v1::DaemonConfig config;
  if (auto error = tribo::daemon::load_daemon_config(config_path, config)) {
    std::fprintf(stderr, "tribo-scorecard: %s\n", error->c_str());
    return 2;
  }
  auto rows = tribo::scorecard::run_scorecard(config, options);
  if (split) tribo::scorecard::assign_roles(rows, *split);
  const std::string name = split ? split->name : "";
  std::cout << (json ? tribo::scorecard::format_json(rows, config_path, name)
                     : tribo::scorecard::format_table(rows, name));
  return 0;
}
