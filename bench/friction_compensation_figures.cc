// The friction compensation's figures (docs/friction_compensation.md), before
// and after, on the backend the config selects: the simulated instrument
// (config/tribod.textproto) or tribo-bench over Modbus
// (config/tribod-modbus.textproto, with tribo-bench running). Runs go through
// the daemon's validator and real-time loop in this process
// (tests/support/compensation_runs.h):
//
//   - break-away at 9810 µN and 4, 18, 36 µm/s (config/protocols/breakaway_velocities.textproto):
//     velocity overshoot and time to the commanded speed, then the RMS
//     tracking error of its reversals at 4 µm/s, in steady sliding and
//     after each reversal;
//   - the slowest scratch without stick-slip under a 10 Hz loop (the
//     scorecard's experiment; simulated backend only: it reads the tip's
//     true motion);
//   - the same with the model's friction levels 30 % high and low and its
//     sigma0 halved and doubled (--robustness; a variant the validator
//     refuses is reported as refused, with the refusal);
//   - the mean friction of the standard scratch over seeds, with and without.
//
//   build/bench/friction_compensation_figures --config config/tribod.textproto --model REPORT.json
//       [--robustness] [--seeds 5] [--breakaway-seed 1] [--json FILE] [--trace FILE]
//
// Or the break-away and reversal figures of two recorded runs of
// breakaway_velocities.textproto (tribod's, or `tribo run --out`):
//
//   build/bench/friction_compensation_figures --before RUN_DIR --after RUN_DIR
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "client/run_summary.h"
#include "daemon/daemon_config.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_documents.h"
#include "proto/text_format_file.h"
#include "tests/support/compensation_runs.h"

namespace {

using tribo::testing::InProcessRun;
using Json = nlohmann::ordered_json;

struct Variant {
  std::string name;
  std::string report;  // empty: no compensation
};

constexpr double kSpeeds[] = {4e-6, 18e-6, 36e-6};
constexpr double kStickSlipSpeeds[] = {0.2e-6, 0.15e-6, 0.1e-6, 0.07e-6, 0.05e-6, 0.03e-6, 0.02e-6,
                                       0.015e-6, 0.01e-6, 0.007e-6, 0.005e-6};

double mean_friction_un(const tribo::v1::DaemonConfig& config, const tribo::v1::Protocol& protocol, std::uint64_t seed) {
  const InProcessRun run = tribo::testing::run_in_process(config, protocol, seed);
  tribo::client::RunResult result;
  result.start = run.start;
  for (const tribo::Sample& s : run.samples) tribo::append_sample(s, result.samples);
  // The summary `tribo run` prints: the friction of its scratch.
  const tribo::v1::RunSummary summary = tribo::client::summarize_run(result);
  return summary.scratches_size() > 0 ? summary.scratches(0).mean_friction_un() : std::nan("");
}

// The break-away and tracking figures of one run, as a table row.
std::string figures_row(const std::string& name, const InProcessRun& run, bool simulated, Json& row) {
  const auto slides = tribo::testing::segments_named(run, "slide");
  std::string os, tos, tts;
  row["model"] = name;
  for (std::size_t i = 0; i < slides.size() && i < 3; ++i) {
    const auto b = tribo::testing::breakaway_figures(run, slides[i]);
    os += fmt::format("{}{:.2f}", i ? " / " : "", b.overshoot);
    tos += fmt::format("{}{:.2f}", i ? " / " : "", b.true_overshoot);
    tts += fmt::format("{}{:.3f}", i ? " / " : "", b.time_to_speed_s);
    row["breakaway"].push_back({{"commanded_um_per_s", b.commanded_m_per_s * 1e6},
                                {"overshoot", b.overshoot},
                                {"true_overshoot", simulated ? Json(b.true_overshoot) : Json(nullptr)},
                                {"time_to_speed_s", b.time_to_speed_s},
                                {"stiction_peak_uN", b.stiction_peak_n * 1e6},
                                {"true_stiction_peak_uN", simulated ? Json(b.true_stiction_peak_n * 1e6) : Json(nullptr)}});
  }
  const auto t = tribo::testing::tracking_figures(run, "stroke");
  const auto x = tribo::testing::run_extremes(run);
  row["tracking"] = {{"steady_rms_um", t.steady_rms_m * 1e6}, {"lag_um", t.steady_mean_abs_m * 1e6},
                     {"reversal_rms_um", t.reversal_rms_m * 1e6}, {"reversal_max_um", t.reversal_max_m * 1e6}};
  row["max_abs_lateral_force_uN"] = x.max_abs_lateral_force_n * 1e6;
  row["max_abs_compensation_uN"] = simulated ? Json(x.max_abs_compensation_n * 1e6) : Json(nullptr);
  row["outcome"] = x.tripped ? "tripped: " + x.trip : "completed";
  return fmt::format("| {} | {} | {} | {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.0f} | {} |\n", name, os,
                     simulated ? tos : "-", tts, t.steady_rms_m * 1e6, t.steady_mean_abs_m * 1e6,
                     t.reversal_rms_m * 1e6, t.reversal_max_m * 1e6, x.max_abs_lateral_force_n * 1e6,
                     x.tripped ? "tripped: " + x.trip : "completed");
}

// Each break-away's ticks, from 0.2 s before the slide begins to 0.5 s into
// it: the setpoint and the plate's true position, the drive (PID output plus
// compensation), the compensation, and the contact's true friction and tilt.
void write_trace(std::ofstream& out, const std::string& name, const InProcessRun& run) {
  const auto slides = tribo::testing::segments_named(run, "slide");
  for (std::size_t i = 0; i < slides.size() && i < 3; ++i) {
    const double start = run.start.segments(static_cast<int>(slides[i])).start_s();
    const auto first = static_cast<std::size_t>(std::max(0.0, std::floor((start - 0.2) / run.loop_period_s)));
    const auto end = std::min(run.drive_n.size(), static_cast<std::size_t>(std::ceil((start + 0.5) / run.loop_period_s)));
    // The sample's setpoint at this tick: the 1 kHz record's nearest.
    std::size_t j = 0;
    for (std::size_t k = first; k < end; ++k) {
      const double t = static_cast<double>(k + 1) * run.loop_period_s;
      while (j + 1 < run.samples.size() && run.samples[j + 1].time_s <= t) ++j;
      out << fmt::format("{},{:g},{:.5f},{:.6f},{:.6f},{:.3f},{:.3f},{:.3f},{:.3f}\n", name, kSpeeds[i] * 1e6, t - start,
                         run.samples[j].lateral_setpoint_m * 1e6, run.true_position_m[k] * 1e6, run.drive_n[k] * 1e6,
                         run.compensation_n[k] * 1e6, run.true_friction_n[k] * 1e6, run.true_tilt_n[k] * 1e6);
    }
  }
}

// When each break-away happens (simulated backend: the per-tick truth),
// against what the compensation does: the contact's friction peak (+: against
// the motion), how far the tip and the setpoint had moved by then, and the
// compensation's largest value and its value at that peak; the sliding
// friction and compensation are the means over the slide's second half.
std::string timing_rows(const std::string& name, const InProcessRun& run) {
  std::string out;
  const auto slides = tribo::testing::segments_named(run, "slide");
  for (std::size_t i = 0; i < slides.size() && i < 3; ++i) {
    const auto& seg = run.start.segments(static_cast<int>(slides[i]));
    const auto t0 = static_cast<std::size_t>(std::llround(seg.start_s() / run.loop_period_s));
    const auto t1 = std::min(run.true_friction_n.size(),
                             t0 + static_cast<std::size_t>(std::llround(seg.duration_s() / run.loop_period_s)));
    if (t1 <= t0 + 2) continue;
    std::size_t peak = t0, comp_peak = t0;
    double friction_sum = 0, comp_sum = 0;
    const std::size_t half = t0 + (t1 - t0) / 2;
    for (std::size_t k = t0; k < t1; ++k) {
      if (run.true_friction_n[k] > run.true_friction_n[peak]) peak = k;
      if (run.compensation_n[k] > run.compensation_n[comp_peak]) comp_peak = k;
      if (k >= half) {
        friction_sum += run.true_friction_n[k];
        comp_sum += run.compensation_n[k];
      }
    }
    const double n = static_cast<double>(t1 - half);
    const double at = static_cast<double>(peak - t0) * run.loop_period_s;
    out += fmt::format("| {} | {:g} | {:.0f} at {:.3f} s | {:.3f} | {:.3f} | {:.0f} | {:.0f} at {:.3f} s | {:.0f} | {:.0f} |\n",
                       name, kSpeeds[i] * 1e6, run.true_friction_n[peak] * 1e6, at,
                       (run.true_position_m[peak] - run.true_position_m[t0]) * 1e6, kSpeeds[i] * at * 1e6,
                       friction_sum / n * 1e6, run.compensation_n[comp_peak] * 1e6,
                       static_cast<double>(comp_peak - t0) * run.loop_period_s, run.compensation_n[peak] * 1e6,
                       comp_sum / n * 1e6);
  }
  return out;
}

constexpr const char* kTimingHead =
    "| model | µm/s | contact's peak, µN | tip's advance then, µm | setpoint's advance then, µm | sliding friction, µN | "
    "largest compensation, µN | compensation at the peak, µN | sliding compensation, µN |\n"
    "|---|---|---|---|---|---|---|---|---|\n";

constexpr const char* kTableHead =
    "| model | overshoot 4 / 18 / 36 µm/s | true (1 ms) | time to speed, s | steady RMS, µm | "
    "lag, µm | reversal RMS, µm | reversal max, µm | peak |F|, µN | outcome |\n"
    "|---|---|---|---|---|---|---|---|---|---|\n";

std::string read_text(const std::string& path) {
  auto text = tribo::wire::read_file(path);
  if (!text) throw std::runtime_error("cannot read " + path);
  return *text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("The friction compensation's figures, before and after (docs/friction_compensation.md)");
  std::string config_path = "config/tribod.textproto", model_path, json_path, before_dir, after_dir;
  bool robustness = false, stick_slip = true;
  int seeds = 5;
  std::uint64_t breakaway_seed = 1;
  app.add_option("--config", config_path, "daemon config: the backend and the loop");
  auto* model = app.add_option("--model", model_path, "tribo-fit diagnose --json report to compensate with");
  auto* before = app.add_option("--before", before_dir, "a recorded run of breakaway_velocities without compensation");
  auto* after = app.add_option("--after", after_dir, "the same run with compensation");
  before->needs(after);
  after->needs(before);
  model->excludes(before);
  app.add_flag("--robustness", robustness, "also the model with levels x1.3, x0.7 and sigma0 x0.5, x2");
  app.add_flag("--stick-slip,!--no-stick-slip", stick_slip, "the 10 Hz loop's stick-slip (simulated backend)");
  app.add_option("--seeds", seeds, "seeds 1..N for the mean friction of the standard scratch (0: skip)");
  app.add_option("--breakaway-seed", breakaway_seed, "the simulated instrument's seed of the break-away runs")
      ->check(CLI::PositiveNumber);
  app.add_option("--json", json_path, "also write the figures as JSON");
  std::string trace_path;
  app.add_option("--trace", trace_path,
                 "write each break-away's ticks (simulated backend) as CSV: from 0.2 s before the slide to 0.5 s into it");
  CLI11_PARSE(app, argc, argv);
  if (!before_dir.empty()) {
    // Two recorded runs: the figures the records give.
    Json out, row;
    std::cout << "## Break-away at 9810 µN and reversals at 4 µm/s, from the records\n\n" << kTableHead;
    for (const auto& [name, dir] : {std::pair{std::string("before: ") + before_dir, before_dir},
                                    std::pair{std::string("after: ") + after_dir, after_dir}}) {
      const InProcessRun run = tribo::testing::recorded_run(dir);
      std::cout << figures_row(name, run, false, row);
      out["breakaway"].push_back(row);
      row = Json();
    }
    const auto start = tribo::testing::recorded_run(after_dir).start;
    for (const auto& use : start.friction_models()) {
      std::cout << fmt::format("\nafter: compensated with {} ({}), SHA-256 {}, {} segments\n", use.report_file(),
                               use.contact(), use.report_sha256(), use.segments_size());
    }
    if (!json_path.empty()) std::ofstream(json_path) << out.dump(1) << "\n";
    return 0;
  }
  if (model_path.empty()) {
    std::cerr << "give --model REPORT, or --before DIR --after DIR\n";
    return 2;
  }

  tribo::v1::DaemonConfig config;
  if (auto error = tribo::daemon::load_daemon_config(config_path, config)) {
    std::cerr << error->c_str() << "\n";
    return 2;
  }
  const bool simulated = config.backend_case() == tribo::v1::DaemonConfig::kSim;
  const std::string report = read_text(model_path);
  std::vector<Variant> variants = {{"without", ""}, {"with the model", report}};
  if (robustness) {
    variants.push_back({"levels x1.3", tribo::testing::scaled_report(report, 1.3, 1)});
    variants.push_back({"levels x0.7", tribo::testing::scaled_report(report, 0.7, 1)});
    variants.push_back({"sigma0 x0.5", tribo::testing::scaled_report(report, 1, 0.5)});
    variants.push_back({"sigma0 x2", tribo::testing::scaled_report(report, 1, 2)});
  }
  Json out;
  out["config"] = config_path;
  out["model"] = model_path;
  out["model_sha256"] = tribo::daemon::sha256_hex(report);
  out["overshoot_filter"] = "least-squares slope of the recorded position over a centred 10 ms window";

  const tribo::v1::Protocol breakaway = tribo::testing::shipped_protocol("breakaway_velocities.textproto");
  std::cout << "## Break-away at 9810 µN and reversals at 4 µm/s (seed " << breakaway_seed << ", " << config_path
            << ")\n\n";
  std::cout << kTableHead;
  std::map<std::string, std::vector<double>> overshoots;
  std::vector<std::pair<std::string, std::string>> timing;
  std::ofstream trace;
  if (!trace_path.empty()) {
    trace.open(trace_path);
    trace << "model,commanded_um_per_s,t_s,setpoint_um,true_position_um,drive_uN,compensation_uN,true_friction_uN,"
             "true_tilt_uN\n";
  }
  for (const Variant& v : variants) {
    const tribo::v1::Protocol protocol = tribo::testing::with_friction_model(breakaway, v.report);
    // A variant the validator refuses (a model scaled beyond the supervisor's
    // compensation limit) is a figure too: tribod would not run it.
    const tribo::daemon::ProtocolCheck check = tribo::daemon::validate_protocol(protocol, config);
    if (!check.ok()) {
      const std::string refusal = check.errors.front().field + ": " + check.errors.front().message;
      std::cout << fmt::format("| {} | - | - | - | - | - | - | - | - | refused: {} |\n", v.name, refusal);
      out["breakaway"].push_back({{"model", v.name}, {"outcome", "refused: " + refusal}});
      continue;
    }
    const InProcessRun run = tribo::testing::run_in_process(config, protocol, breakaway_seed);
    Json row;
    if (!trace_path.empty() && simulated) write_trace(trace, v.name, run);
    if (simulated) timing.emplace_back(v.name, timing_rows(v.name, run));
    std::cout << figures_row(v.name, run, simulated, row);
    for (const Json& b : row["breakaway"]) overshoots[v.name].push_back(b["overshoot"].get<double>());
    out["breakaway"].push_back(row);
  }
  if (simulated) {
    std::cout << "\nBreak-away timing (the simulated tip's truth; times from the slide's start):\n\n" << kTimingHead;
    for (const auto& [name, rows] : timing) std::cout << rows;
  }
  if (variants.size() > 2 && overshoots.contains("with the model")) {
    std::cout << "\nShare of the overshoot's reduction that remains (4 / 18 / 36 µm/s):\n\n";
    const auto& before = overshoots["without"];
    const auto& nominal = overshoots["with the model"];
    for (std::size_t k = 2; k < variants.size(); ++k) {
      if (!overshoots.contains(variants[k].name)) continue;  // refused
      const auto& o = overshoots[variants[k].name];
      std::string text;
      for (std::size_t i = 0; i < o.size(); ++i) {
        text += fmt::format("{}{:.0f} %", i ? " / " : "", 100 * (before[i] - o[i]) / (before[i] - nominal[i]));
      }
      std::cout << "- " << variants[k].name << ": " << text << "\n";
    }
  }

  if (stick_slip && simulated) {
    std::cout << "\n## Stick-slip with a 10 Hz loop (1 mN, seed 1): the tip's largest advance per 0.1 s / "
                 "commanded (> 3: stick-slip)\n\n| model |";
    for (double v : kStickSlipSpeeds) std::cout << fmt::format(" {:g} |", v * 1e6);
    std::cout << " slowest smooth, µm/s |\n|---|";
    for (std::size_t i = 0; i <= std::size(kStickSlipSpeeds); ++i) std::cout << "---|";
    std::cout << "\n";
    for (const Variant& v : variants) {
      tribo::daemon::FrictionReport parsed;
      if (!v.report.empty()) parsed = std::get<tribo::daemon::FrictionReport>(tribo::daemon::read_friction_report(v.report));
      std::cout << "| " << v.name << " |";
      double slowest = std::nan("");
      Json row;
      row["model"] = v.name;
      for (double speed : kStickSlipSpeeds) {
        const double ratio =
            tribo::testing::stick_slip_ratio(config, v.report.empty() ? nullptr : &parsed.model, 10, speed, 1);
        if (ratio <= 3) slowest = speed;
        row["ratios"].push_back({{"velocity_um_per_s", speed * 1e6}, {"ratio", ratio}});
        std::cout << fmt::format(" {:.2f} |", ratio);
      }
      row["slowest_smooth_um_per_s"] = slowest * 1e6;
      out["stick_slip_10hz"].push_back(row);
      std::cout << fmt::format(" {:g} |\n", slowest * 1e6);
    }
  }

  if (seeds > 0) {
    std::cout << "\n## Mean friction of the standard scratch (997 µN, 0.5 µm/s), as the run summary reports it\n\n"
                 "| seed | without, µN | with, µN | difference, µN |\n|---|---|---|---|\n";
    const tribo::v1::Protocol scratch = tribo::testing::shipped_protocol("standard_scratch.textproto");
    double sum_d = 0, sum_dd = 0, sum_a = 0, sum_aa = 0;
    for (int seed = 1; seed <= seeds; ++seed) {
      const double a = mean_friction_un(config, scratch, static_cast<std::uint64_t>(seed));
      const double b = mean_friction_un(config, tribo::testing::with_friction_model(scratch, report),
                                        static_cast<std::uint64_t>(seed));
      sum_d += b - a;
      sum_dd += (b - a) * (b - a);
      sum_a += a;
      sum_aa += a * a;
      out["mean_friction"].push_back({{"seed", seed}, {"without_uN", a}, {"with_uN", b}});
      std::cout << fmt::format("| {} | {:.3f} | {:.3f} | {:+.4f} |\n", seed, a, b, b - a);
    }
    const double n = seeds, mean_d = sum_d / n, mean_a = sum_a / n;
    const double sd_a = n > 1 ? std::sqrt(std::max(0.0, (sum_aa - n * mean_a * mean_a) / (n - 1))) : 0.0;
    const double sd_d = n > 1 ? std::sqrt(std::max(0.0, (sum_dd - n * mean_d * mean_d) / (n - 1))) : 0.0;
    std::cout << fmt::format("\nmean difference {:+.4f} µN (sd {:.4f} µN over the seeds); the uncompensated "
                             "friction spreads by sd {:.2f} µN over the seeds\n",
                             mean_d, sd_d, sd_a);
  }
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(1) << "\n";
  return 0;
}
