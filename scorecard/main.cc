// tribo-scorecard: runs the dissertation's experiments on a configuration of
// the simulated instrument and prints observation | dissertation | simulated
// | error (docs/simulated_instrument.md).
//
//   tribo-scorecard [--config FILE] [--quick] [--group NAME]... [--seed N] [--json]
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>

#include "daemon/daemon_config.h"
#include "scorecard/scorecard.h"

int main(int argc, char** argv) {
  CLI::App app{"Reproduction scorecard: the dissertation's measurements vs the simulated instrument"};
  std::string config_path = TRIBO_SOURCE_DIR "/config/tribod.textproto";
  tribo::scorecard::ScorecardOptions options;
  bool json = false;
  app.add_option("--config", config_path, "daemon config (its sim and controller sections are used)");
  app.add_flag("--quick", options.quick, "skip the 1000 s experiments (Fig. 4.22's longest rest, Fig. 3.12)");
  app.add_option("--group", options.groups, "table_5_1, fig_4_22, velocity, fig_3_12, amontons, noise, stick_slip (default: all)")
      ->check(CLI::IsMember(std::vector<std::string>(tribo::scorecard::kGroups.begin(), tribo::scorecard::kGroups.end())));
  app.add_option("--seed", options.seed, "seed of the simulated instrument");
  app.add_flag("--json", json, "print JSON instead of a table");
  CLI11_PARSE(app, argc, argv);

  tribo::v1::DaemonConfig config;
  if (auto error = tribo::daemon::load_daemon_config(config_path, config)) {
    std::fprintf(stderr, "tribo-scorecard: %s\n", error->c_str());
    return 2;
  }
  const auto rows = tribo::scorecard::run_scorecard(config, options);
  std::cout << (json ? tribo::scorecard::format_json(rows, config_path) : tribo::scorecard::format_table(rows));
  return 0;
}
