// tribo-fit: friction identification on measured data (see docs/tribo_fit.md).
//   tribo-fit diagnose INPUT ...   residual diagnosis over the effect vocabulary
//   tribo-fit stribeck FILE.csv ...  steady-state curve fit (LuGre or eq. 44)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/diagnosis.h"
#include "analysis/diagnosis_report.h"
#include "analysis/json_writer.h"
#include "analysis/scratch_metrics.h"
#include "analysis/series_input.h"
#include "proto/run_files.h"
#include "analysis/stribeck_fit.h"

namespace {

using namespace tribo::analysis;

constexpr const char* kUsage = R"(usage:
  tribo-fit diagnose INPUT [options]
  tribo-fit stribeck FILE.csv --x COL --y COL [--weight COL] [--model lugre|eq44]
                     [--stribeck-exponent D] [--no-offset] [--json]
  tribo-fit metrics RUN_DIR [--json]
  tribo-fit --help

diagnose: fits the LuGre friction model to a measured run (driven by the measured
motion), traces what it gets wrong to an effect of the vocabulary
  dwell_stiction frictional_lag velocity_strengthening load_dependence
  position_periodic direction_asymmetry tilt_offset drift presliding_hysteresis
  backlash
adds an effect only if it clearly lowers the error on held-out passes, and
reports the error before and after.

INPUT is a CSV file with a header line (name the columns below), or a tribo run
directory (samples.csv + metadata.json; its columns are known).
All columns are in SI units: time s, position m, velocity m/s, acceleration
m/s^2, forces N (or one consistent unit, e.g. a stress in Pa, see --force-unit).

  --time COL            time (s)                                  required for CSV
  --position COL        position of the moving body (m)           required for CSV
  --force COL           force that drives the motion against friction (N),
                        positive when it pushes towards +x        required for CSV
  --motor-force COL     a drive force that also accelerates the moving mass:
                        --force COL --fit-mass
  --fit-mass            fit a moving mass M: the force includes M a
  --normal COL          normal load (N); friction levels then scale with it
                        (Amontons) unless --no-load-scaling
  --velocity COL        velocity (m/s); else derived from the position
  --acceleration COL    acceleration (m/s^2); else derived from the velocity
  --reference COL       commanded position (m), kept for the plots
  --force-sign S        multiply the force column by S (1 or -1)
  --force-unit U        unit of the force column in the report (default N)
  --no-load-scaling     constant friction levels even with a normal channel
  --stribeck-exponent D 1 (default, the dissertation's exponential) or 2
  --smooth S            moving-average window (s) before differentiating
  --effects LIST        comma-separated candidates (default: all ten)
  --begin S, --end S    analyse only samples with begin <= t <= end
  --json                print one JSON object (fields: see README)
  --out DIR             also write DIR/diagnosis.json, traces.csv and
                        signatures.csv (plots: analysis/plot_diagnosis.py DIR)

stribeck: fits a steady-state curve to points (x, y[, weight]): the LuGre steady
state F(v) = sgn(v)(Fc + (Fs - Fc) exp(-(|v|/vs)^D)) + Fv v [+ offset], or eq. 44
mu(x) = p1 + p2 exp(-p3 x) + p4 x, globally (no initial guess), with robust weights.

metrics: the scratch metrics of a recorded tribo run: per loaded sliding segment
the mean friction, mu, stiction peak Fs, stretch time ts and distance ds, steady
lag dl and the Table 5.1 gains sigma = Fs/ds, mki = 2 Fs/(v0 ts^2), mk = mki dl/v0;
the lateral-force drift in loaded holds; the surface tilt (normal displacement
against lateral position over the first moving segment at constant load).
Printed in µm, µN, s as in Table 5.1; --json prints SI units.

exit codes: 0 done; 1 the input could not be read or analysed; 2 bad usage
)";

struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;
  std::vector<std::string> flags;
  bool flag(const std::string& f) const { return std::find(flags.begin(), flags.end(), f) != flags.end(); }
  std::optional<std::string> get(const std::string& k) const {
    auto it = options.find(k);
    if (it == options.end()) return std::nullopt;
    return it->second;
  }
};

const std::vector<std::string> kFlags = {"--json", "--fit-mass", "--no-load-scaling", "--no-offset", "--help"};

std::optional<Args> parse(int argc, char** argv, std::string& error) {
  Args a;
  for (int i = 2; i < argc; ++i) {
    const std::string s = argv[i];
    if (s.rfind("--", 0) == 0) {
      if (std::find(kFlags.begin(), kFlags.end(), s) != kFlags.end()) {
        a.flags.push_back(s);
      } else if (i + 1 < argc) {
        a.options[s] = argv[++i];
      } else {
        error = "option " + s + " needs a value";
        return std::nullopt;
      }
    } else {
      a.positional.push_back(s);
    }
  }
  return a;
}

bool parse_number(const std::string& text, double& value) {
  std::istringstream in(text);
  in >> value;
  return !in.fail() && in.eof();
}

int usage_error(const std::string& message) {
  std::cerr << "tribo-fit: " << message << "\n\n" << kUsage;
  return 2;
}

int diagnose_command(int argc, char** argv) {
  std::string error;
  const auto args = parse(argc, argv, error);
  if (!args) return usage_error(error);
  static const std::vector<std::string> known = {"--time", "--position", "--force", "--motor-force", "--normal", "--velocity",
                                                 "--acceleration", "--reference", "--force-sign", "--force-unit",
                                                 "--stribeck-exponent", "--smooth", "--effects", "--begin", "--end", "--out"};
  for (const auto& [k, v] : args->options) {
    if (std::find(known.begin(), known.end(), k) == known.end()) return usage_error("unknown option " + k);
  }
  if (args->positional.size() != 1) return usage_error("diagnose takes one INPUT (a CSV file or a run directory)");
  const std::filesystem::path input = args->positional[0];
  std::vector<Effect> candidates(kAllEffects.begin(), kAllEffects.end());
  if (auto list = args->get("--effects")) {
    candidates.clear();
    std::stringstream in(*list);
    std::string name;
    while (std::getline(in, name, ',')) {
      const auto e = effect_from_name(name);
      if (!e) return usage_error("unknown effect '" + name + "'");
      candidates.push_back(*e);
    }
  }

  std::optional<MeasuredSeries> series;
  bool fit_mass = args->flag("--fit-mass");
  if (std::filesystem::is_directory(input)) {
    series = read_run_series(input, error);
  } else {
    ColumnMapping columns;
    columns.time = args->get("--time").value_or("");
    columns.position = args->get("--position").value_or("");
    columns.force = args->get("--force").value_or("");
    if (auto motor = args->get("--motor-force")) {
      if (!columns.force.empty()) return usage_error("give either --force or --motor-force");
      columns.force = *motor;
      fit_mass = true;
    }
    if (columns.time.empty() || columns.position.empty() || columns.force.empty()) {
      return usage_error("a CSV input needs --time, --position and --force (or --motor-force)");
    }
    columns.normal = args->get("--normal").value_or("");
    columns.velocity = args->get("--velocity").value_or("");
    columns.acceleration = args->get("--acceleration").value_or("");
    columns.reference = args->get("--reference").value_or("");
    columns.force_unit = args->get("--force-unit").value_or("N");
    if (auto sign = args->get("--force-sign")) {
      if (!parse_number(*sign, columns.force_scale) || (columns.force_scale != 1 && columns.force_scale != -1)) {
        return usage_error("--force-sign must be 1 or -1");
      }
    }
    series = read_csv_series(input, columns, error);
  }
  if (!series) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }

  double begin = -HUGE_VAL, end = HUGE_VAL, smooth = 0, exponent = 1;
  if (auto v = args->get("--begin"); v && !parse_number(*v, begin)) return usage_error("--begin needs a number");
  if (auto v = args->get("--end"); v && !parse_number(*v, end)) return usage_error("--end needs a number");
  if (auto v = args->get("--smooth"); v && (!parse_number(*v, smooth) || smooth < 0)) return usage_error("--smooth needs a number >= 0");
  if (auto v = args->get("--stribeck-exponent"); v && (!parse_number(*v, exponent) || exponent <= 0)) {
    return usage_error("--stribeck-exponent needs a number > 0");
  }
  if (begin > -HUGE_VAL || end < HUGE_VAL) {
    std::size_t first = 0, last = series->size();
    while (first < series->size() && series->time_s[first] < begin) ++first;
    while (last > first && series->time_s[last - 1] > end) --last;
    *series = slice(*series, first, last);
  }
  if (const std::string problem = check_series(*series); !problem.empty()) {
    std::cerr << "tribo-fit: " << input.string() << ": " << problem << "\n";
    return 1;
  }
  derive_motion(*series, smooth);

  DiagnosisOptions options;
  options.base.fit_mass = fit_mass;
  options.base.load_scaled = series->has_normal() && !args->flag("--no-load-scaling");
  options.base.stribeck_exponent = exponent;
  // A tribo run: holds, directions and passes from the setpoint; each pass
  // starts from the force measured at rest (the loop's dither relaxes the
  // contact in holds in a way the record cannot show).
  const bool tribo_run = std::filesystem::is_directory(input);
  options.segmentation.segment_by_reference = tribo_run;
  options.base.state_from_rest = tribo_run;
  options.candidates = candidates;
  const auto t0 = std::chrono::steady_clock::now();
  Diagnosis d;
  try {
    d = diagnose(*series, options);
  } catch (const std::exception& e) {
    std::cerr << "tribo-fit: the analysis failed: " << e.what() << "\n";
    return 1;
  }
  ReportInfo info;
  for (int i = 0; i < argc; ++i) info.command_line += (i ? " " : "") + std::string(argv[i]);
  info.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string json = diagnosis_json(*series, d, info);
  if (auto out = args->get("--out")) {
    if (!write_diagnosis_files(*out, *series, d, json, error)) {
      std::cerr << "tribo-fit: " << error << "\n";
      return 1;
    }
  }
  std::cout << (args->flag("--json") ? json : diagnosis_text(*series, d));
  return 0;
}

int stribeck_command(int argc, char** argv) {
  std::string error;
  const auto args = parse(argc, argv, error);
  if (!args) return usage_error(error);
  if (args->positional.size() != 1) return usage_error("stribeck takes one CSV file");
  const auto x = args->get("--x"), y = args->get("--y");
  if (!x || !y) return usage_error("stribeck needs --x COL and --y COL");
  const auto table = read_csv_columns(args->positional[0], {*x, *y, args->get("--weight").value_or("")}, error);
  if (!table) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }
  std::vector<CurvePoint> points;
  for (std::size_t i = 0; i < (*table)[0].size(); ++i) {
    const double w = (*table)[2].empty() ? 1.0 : (*table)[2][i];
    points.push_back({(*table)[0][i], (*table)[1][i], w});
  }
  double exponent = 1;
  if (auto v = args->get("--stribeck-exponent"); v && !parse_number(*v, exponent)) return usage_error("--stribeck-exponent needs a number");
  const std::string model = args->get("--model").value_or("lugre");
  CurveFit fit;
  try {
    if (model == "lugre") fit = fit_stribeck_curve(points, exponent, !args->flag("--no-offset"));
    else if (model == "eq44") fit = fit_eq44(points);
    else return usage_error("--model is lugre or eq44");
  } catch (const std::exception& e) {
    std::cerr << "tribo-fit: " << e.what() << "\n";
    return 1;
  }
  if (args->flag("--json")) {
    JsonWriter j;
    j.begin_object().field("model", model).key("parameters").begin_array();
    for (std::size_t k = 0; k < fit.names.size(); ++k) {
      j.begin_object().field("name", fit.names[k]).field("value", fit.values[k]).field("std_error", fit.std_errors[k]).end_object();
    }
    j.end_array().field("rms", fit.rms).key("robust_weights").begin_array();
    for (double w : fit.robust_weights) j.value(w);
    j.end_array().key("warnings").begin_array();
    for (const auto& w : fit.warnings) j.value(w);
    j.end_array().end_object();
    std::cout << j.str();
  } else {
    for (std::size_t k = 0; k < fit.names.size(); ++k) {
      std::printf("%-8s %14.6g +- %.3g\n", fit.names[k].c_str(), fit.values[k], fit.std_errors[k]);
    }
    std::printf("weighted RMS residual %.4g\n", fit.rms);
    for (const auto& w : fit.warnings) std::printf("warning: %s\n", w.c_str());
  }
  return 0;
}

int metrics_command(int argc, char** argv) {
  std::string error;
  const auto args = parse(argc, argv, error);
  if (!args) return usage_error(error);
  if (args->positional.size() != 1) return usage_error("metrics takes one run directory");
  const auto run = tribo::wire::read_run_directory(args->positional[0], error);
  if (!run) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }
  const auto scratches = scratch_identification(run->samples);
  const auto drift = lateral_drift_from_holds(run->samples);
  const auto tilt = fit_surface_tilt(run->samples);
  if (args->flag("--json")) {
    JsonWriter j;
    j.begin_object().key("scratches").begin_array();
    for (const auto& s : scratches) {
      const auto& m = s.metrics;
      j.begin_object().field("segment", static_cast<int>(m.segment)).field("velocity_m_per_s", m.velocity_m_per_s);
      j.field("normal_force_n", m.normal_force_n).field("mean_friction_n", m.mean_friction_n).field("mu", m.mu);
      j.field("stiction_peak_n", m.stiction_peak_n).field("stretch_time_s", s.stretch_time_s);
      j.field("stretch_distance_m", s.stretch_distance_m).field("steady_lag_m", m.steady_lag_m);
      j.field("contact_stiffness_n_per_m", s.gains.contact_stiffness_n_per_m).field("mki_n_per_m_s", s.gains.integral_gain);
      j.field("mk_n_per_m", s.gains.proportional_gain).end_object();
    }
    j.end_array().key("drift").begin_object().field("mean_rate_n_per_s", drift.mean_rate_n_per_s).key("holds").begin_array();
    for (const auto& h : drift.holds) {
      j.begin_object().field("segment", static_cast<int>(h.segment)).field("duration_s", h.duration_s);
      j.field("rate_n_per_s", h.rate_n_per_s).field("rate_std_error", h.rate_std_error).end_object();
    }
    j.end_array().end_object().key("tilt");
    if (tilt) j.begin_object().field("segment", static_cast<int>(tilt->segment)).field("slope", tilt->slope).field("samples", tilt->samples).end_object();
    else j.null();
    j.end_object();
    std::cout << j.str();
    return 0;
  }
  for (const auto& s : scratches) {
    const auto& m = s.metrics;
    std::printf("segment %u: v0 %+.3f um/s at %.1f uN: friction %.2f uN, mu %.4f\n", m.segment, 1e6 * m.velocity_m_per_s,
                1e6 * m.normal_force_n, 1e6 * m.mean_friction_n, m.mu);
    std::printf("  Fs %.2f uN, ts %.4f s, ds %.4f um, dl %.4f um -> sigma %.1f uN/um, mki %.1f, mk %.1f (Table 5.1 units)\n",
                1e6 * m.stiction_peak_n, s.stretch_time_s, 1e6 * s.stretch_distance_m, 1e6 * m.steady_lag_m,
                s.gains.contact_stiffness_n_per_m, s.gains.integral_gain, s.gains.proportional_gain);
  }
  for (const auto& h : drift.holds) {
    std::printf("hold segment %u (%.2f s): lateral-force drift %.4g +- %.2g uN/s\n", h.segment, h.duration_s, 1e6 * h.rate_n_per_s,
                1e6 * h.rate_std_error);
  }
  if (tilt) std::printf("surface tilt (segment %u): %.5f (%.3f deg)\n", tilt->segment, tilt->slope, std::atan(tilt->slope) * 180 / M_PI);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage_error("missing command");
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    std::cout << kUsage;
    return 0;
  }
  for (int i = 2; i < argc; ++i) {
    if (std::string(argv[i]) == "--help") {
      std::cout << kUsage;
      return 0;
    }
  }
  if (command == "diagnose") return diagnose_command(argc, argv);
  if (command == "stribeck") return stribeck_command(argc, argv);
  if (command == "metrics") return metrics_command(argc, argv);
  return usage_error("unknown command '" + command + "'");
}
