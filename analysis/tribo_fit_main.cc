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

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "analysis/diagnosis.h"
#include "analysis/report/diagnosis_report.h"
#include "analysis/fit_commands.h"
#include "analysis/metrics/scratch_metrics.h"
#include "analysis/input/series_input.h"
#include "proto/run_files.h"
#include "analysis/effects/steady_state_diagnosis.h"
#include "analysis/models/stribeck_fit.h"

namespace {

using namespace tribo::analysis;

constexpr const char* kSummary = R"(tribo-fit: friction identification on measured data.
  tribo-fit diagnose INPUT [options]    residual diagnosis over the effect vocabulary
  tribo-fit stribeck FILE.csv --x COL --y COL [options]   steady-state curve fit
  tribo-fit metrics RUN_DIR [--json]    scratch metrics of a recorded tribo run
  tribo-fit COMMAND --help              the command's options
All columns are in SI units: time s, position m, velocity m/s, acceleration
m/s^2, forces N (or one consistent unit, e.g. a stress in Pa, see --force-unit).
exit codes: 0 done; 1 the input could not be read or analysed; 2 bad usage)";

constexpr const char* kDiagnoseFooter = R"(
diagnose fits the LuGre friction model to a measured run (driven by the measured
motion), traces what it gets wrong to an effect of the vocabulary
  dwell_stiction frictional_lag velocity_strengthening load_dependence
  position_periodic direction_asymmetry tilt_offset drift presliding_hysteresis
  backlash rate_state
adds an effect only if it clearly lowers the error on held-out passes and its
fitted values lie within physical bounds, and reports the error before and
after (every warning, and the final model, in the text report as in the JSON).
INPUT is a CSV file with a header line (name the columns), or a tribo run
directory (samples.csv + metadata.json; its columns are known). All columns
are in SI units. Without --velocity the motion (velocity, acceleration) is
estimated from the position by a Rauch-Tung-Striebel smoother whose noise
floor and motion-model intensity are estimated from the record (reported).)";

constexpr const char* kStribeckFooter = R"(
stribeck fits a steady-state curve to points (x, y[, weight]): the LuGre steady
state F(v) = sgn(v)(Fc + (Fs - Fc) exp(-(|v|/vs)^D)) + Fv v [+ offset], or eq. 44
mu(x) = p1 + p2 exp(-p3 x) + p4 x, globally (no initial guess), with robust weights.
With --diagnose, points are (signed velocity, friction force[, load]) on plateaus and
the effect report decides on held-out points (leave-one-out up to 200 points, else
10 folds): the base (Coulomb + viscous, or with the Stribeck term), then
direction_asymmetry (levels and viscous friction per direction),
velocity_strengthening (k ln(|v|/v_ref), k > 0) and, with --load, load_dependence
(levels ~ load^p, p free instead of 1).)";

constexpr const char* kMetricsFooter = R"(
metrics: the scratch metrics of a recorded tribo run: per loaded sliding segment
the mean friction, mu, stiction peak Fs, stretch time ts and distance ds, steady
lag dl and the Table 5.1 gains sigma = Fs/ds, mki = 2 Fs/(v0 ts^2), mk = mki dl/v0;
the lateral-force drift in loaded holds; the surface tilt (normal displacement
against lateral position over the first moving segment at constant load).
Printed in µm, µN, s as in Table 5.1; --json prints SI units.)";

struct DiagnoseArgs {
  std::string input;
  std::string time, position, force, motor_force, normal, velocity, acceleration, reference;
  double force_sign = 1;
  std::string force_unit = "N";
  bool fit_mass = false, no_load_scaling = false, json = false, timings = false;
  double stribeck_exponent = 1, smooth = 0;
  std::string base_model = "lugre";
  std::string dither = "off";
  double min_confusion_z = 0;
  std::string motion_estimator = "rts";
  std::string effects;
  double begin = -HUGE_VAL, end = HUGE_VAL;
  std::string out;
  std::string command_line;
};

struct StribeckArgs {
  std::string file, x, y, weight, load, model = "lugre";
  double stribeck_exponent = 1;
  bool no_offset = false, json = false, diagnose = false;
};

struct MetricsArgs {
  std::string run_dir;
  bool json = false;
};

int usage_error(const std::string& message) {
  std::cerr << "tribo-fit: " << message << "\n(tribo-fit --help, tribo-fit COMMAND --help)\n";
  return 2;
}

int diagnose_command(const DiagnoseArgs& a) {
  std::string error;
  const std::filesystem::path input = a.input;
  std::vector<Effect> candidates(kAllEffects.begin(), kAllEffects.end());
  if (!a.effects.empty()) {
    candidates.clear();
    std::stringstream in(a.effects);
    std::string name;
    while (std::getline(in, name, ',')) {
      const auto e = effect_from_name(name);
      if (!e) return usage_error("unknown effect '" + name + "'");
      candidates.push_back(*e);
    }
  }

  std::optional<PhaseTimings> timings;
  if (a.timings) timings.emplace(std::cerr);
  PhaseTimings* const phases = timings ? &*timings : nullptr;
  std::optional<MeasuredSeries> series;
  bool fit_mass = a.fit_mass;
  if (std::filesystem::is_directory(input)) {
    series = read_run_series(input, error);
  } else {
    ColumnMapping columns;
    columns.time = a.time;
    columns.position = a.position;
    columns.force = a.force;
    if (!a.motor_force.empty()) {
      if (!columns.force.empty()) return usage_error("give either --force or --motor-force");
      columns.force = a.motor_force;
      fit_mass = true;
    }
    if (columns.time.empty() || columns.position.empty() || columns.force.empty()) {
      return usage_error("a CSV input needs --time, --position and --force (or --motor-force)");
    }
    columns.normal = a.normal;
    columns.velocity = a.velocity;
    columns.acceleration = a.acceleration;
    columns.reference = a.reference;
    columns.force_unit = a.force_unit;
    columns.force_scale = a.force_sign;
    series = read_csv_series(input, columns, error);
    if (series) {
      if (const std::string why = implausible_csv_series(*series, columns); !why.empty()) {
        error = input.string() + ": refused before fitting: " + why;
      }
    }
  }
  if (!series || !error.empty()) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }

  mark_phase(phases, "record read");
  DiagnoseRequest request;
  request.timings = phases;
  request.candidates = candidates;
  request.begin_s = a.begin;
  request.end_s = a.end;
  request.fit_mass = fit_mass;
  request.load_scaling = !a.no_load_scaling;
  request.stribeck_exponent = a.stribeck_exponent;
  request.smooth_s = a.smooth;
  request.central_differences = a.motion_estimator == "central";
  request.loop_force = a.motion_estimator == "rts_loop_force";
  request.velocity_jumps = a.motion_estimator == "rts_jumps";
  if (a.motion_estimator == "rts_stretches") request.reference_motion = ReferenceMotion::setpoint_stretches;
  request.motion_by_heldout_force = a.motion_estimator == "auto";
  request.tribo_run = std::filesystem::is_directory(input);
  request.choose_base_contact = a.base_model == "choose";
  request.dither = a.dither == "on" ? DitherTerm::on : (a.dither == "choose" ? DitherTerm::choose : DitherTerm::off);
  request.min_confusion_z = a.min_confusion_z;
  request.command_line = a.command_line;
  const DiagnoseOutcome outcome = diagnose_series(std::move(*series), request);
  if (!outcome.error.empty()) {
    std::cerr << "tribo-fit: " << outcome.error << "\n";
    return 1;
  }
  const std::string& json = outcome.json;
  const Diagnosis& d = outcome.diagnosis;
  if (!a.out.empty()) {
    if (!write_diagnosis_files(a.out, outcome.series, d, json, error)) {
      std::cerr << "tribo-fit: " << error << "\n";
      return 1;
    }
  }
  std::cout << (a.json ? json : diagnosis_text(outcome.series, d));
  std::cout.flush();
  mark_phase(phases, "report written");
  return 0;
}

// --diagnose: the effect report on steady-state points.
int steady_diagnosis_command(const StribeckArgs& a) {
  std::string error;
  const auto table = read_csv_columns(a.file, {a.x, a.y, a.weight, a.load}, error);
  if (!table) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }
  std::vector<SteadyPoint> points;
  for (std::size_t i = 0; i < (*table)[0].size(); ++i) {
    points.push_back({(*table)[0][i], (*table)[1][i], (*table)[3].empty() ? 0.0 : (*table)[3][i],
                      (*table)[2].empty() ? 1.0 : (*table)[2][i]});
  }
  SteadyOptions options;
  options.stribeck_exponent = a.stribeck_exponent;
  options.has_load = !a.load.empty();
  try {
    const SteadyDiagnosis d = diagnose_steady_state(points, options);
    std::cout << (a.json ? steady_diagnosis_json(d) : steady_diagnosis_text(d));
  } catch (const std::exception& e) {
    std::cerr << "tribo-fit: " << a.file << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}

int stribeck_command(const StribeckArgs& a) {
  if (a.diagnose) return steady_diagnosis_command(a);
  if (!a.load.empty()) return usage_error("--load needs --diagnose");
  std::string error;
  const auto table = read_csv_columns(a.file, {a.x, a.y, a.weight}, error);
  if (!table) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }
  std::vector<CurvePoint> points;
  for (std::size_t i = 0; i < (*table)[0].size(); ++i) {
    const double w = (*table)[2].empty() ? 1.0 : (*table)[2][i];
    points.push_back({(*table)[0][i], (*table)[1][i], w});
  }
  const double exponent = a.stribeck_exponent;
  const std::string& model = a.model;
  CurveFit fit;
  try {
    if (model == "lugre") fit = fit_stribeck_curve(points, exponent, !a.no_offset);
    else if (model == "eq44") fit = fit_eq44(points);
    else return usage_error("--model is lugre or eq44");
  } catch (const std::exception& e) {
    std::cerr << "tribo-fit: " << e.what() << "\n";
    return 1;
  }
  if (a.json) {
    nlohmann::ordered_json j;
    j["model"] = model;
    j["parameters"] = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < fit.names.size(); ++k) {
      j["parameters"].push_back({{"name", fit.names[k]}, {"value", fit.values[k]}, {"std_error", fit.std_errors[k]}});
    }
    j["rms"] = fit.rms;
    j["robust_weights"] = fit.robust_weights;
    j["warnings"] = fit.warnings;
    std::cout << j.dump(2) << "\n";
  } else {
    for (std::size_t k = 0; k < fit.names.size(); ++k) {
      std::printf("%-8s %14.6g +- %.3g\n", fit.names[k].c_str(), fit.values[k], fit.std_errors[k]);
    }
    std::printf("weighted RMS residual %.4g\n", fit.rms);
    for (const auto& w : fit.warnings) std::printf("warning: %s\n", w.c_str());
  }
  return 0;
}

int metrics_command(const MetricsArgs& a) {
  std::string error;
  const auto run = tribo::wire::read_run_directory(a.run_dir, error);
  if (!run) {
    std::cerr << "tribo-fit: " << error << "\n";
    return 1;
  }
  const auto scratches = scratch_identification(run->samples);
  const auto drift = lateral_drift_from_holds(run->samples);
  const auto tilt = fit_surface_tilt(run->samples);
  if (a.json) {
    std::cout << metrics_json(run->samples);
    return 0;
  }
  for (const auto& s : scratches) {
    const auto& m = s.metrics;
    std::printf("segment %u: v0 %+.3f µm/s at %.1f µN: friction %.2f µN, mu %.4f\n", m.segment, 1e6 * m.velocity_m_per_s,
                1e6 * m.normal_force_n, 1e6 * m.mean_friction_n, m.mu);
    std::printf("  Fs %.2f µN, ts %.4f s, ds %.4f µm, dl %.4f µm -> sigma %.1f µN/µm, mki %.1f, mk %.1f (Table 5.1 units)\n",
                1e6 * m.stiction_peak_n, s.stretch_time_s, 1e6 * s.stretch_distance_m, 1e6 * m.steady_lag_m,
                s.gains.contact_stiffness_n_per_m, s.gains.integral_gain, s.gains.proportional_gain);
  }
  for (const auto& h : drift.holds) {
    std::printf("hold segment %u (%.2f s): lateral-force drift %.4g +- %.2g µN/s\n", h.segment, h.duration_s, 1e6 * h.rate_n_per_s,
                1e6 * h.rate_std_error);
  }
  if (tilt) std::printf("surface tilt (segment %u): %.5f (%.3f deg)\n", tilt->segment, tilt->slope, std::atan(tilt->slope) * 180 / M_PI);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
#ifdef __GLIBC__
  // One malloc arena for every thread: the fits' jobs run on new threads
  // in each round, and with an arena per thread the memory a job freed
  // stayed resident in its arena (a 198 s tribod record: peak resident
  // 93 -> 74 MB, the same CPU time).
  mallopt(M_ARENA_MAX, 1);
#endif
  CLI::App app{kSummary, "tribo-fit"};
  app.set_version_flag("--version", std::string("tribo-fit ") + TRIBO_VERSION);
  app.require_subcommand(1);

  DiagnoseArgs d;
  for (int i = 0; i < argc; ++i) d.command_line += (i ? " " : "") + std::string(argv[i]);
  auto* diag = app.add_subcommand("diagnose", "residual diagnosis over the effect vocabulary");
  diag->footer(kDiagnoseFooter);
  diag->add_option("INPUT", d.input, "a CSV file with a header line, or a tribo run directory")->required();
  diag->add_option("--time", d.time, "time column (s); required for CSV");
  diag->add_option("--position", d.position, "position of the moving body (m); required for CSV");
  diag->add_option("--force", d.force, "force that drives the motion against friction (N), positive towards +x");
  diag->add_option("--motor-force", d.motor_force, "a drive force that also accelerates the moving mass: --force COL --fit-mass");
  diag->add_flag("--fit-mass", d.fit_mass, "fit a moving mass M: the force includes M a");
  diag->add_option("--normal", d.normal, "normal load (N); friction levels then scale with it unless --no-load-scaling");
  diag->add_option("--velocity", d.velocity, "velocity (m/s); else estimated from the position");
  diag->add_option("--acceleration", d.acceleration, "acceleration (m/s^2); else estimated");
  diag->add_option("--reference", d.reference,
                   "commanded position (m): the motion estimate follows it through the fitted loop, and holds are where it stands still");
  diag->add_option("--force-sign", d.force_sign, "multiply the force column by S (1 or -1)")->check(CLI::IsMember({1.0, -1.0}));
  diag->add_option("--force-unit", d.force_unit, "unit of the force column in the report")->capture_default_str();
  diag->add_flag("--no-load-scaling", d.no_load_scaling, "constant friction levels even with a normal channel");
  diag->add_option("--stribeck-exponent", d.stribeck_exponent, "1 (the dissertation's exponential) or 2 (Gaussian)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  diag->add_option("--smooth", d.smooth, "moving-average window (s) before central differences, instead of the smoother")
      ->check(CLI::NonNegativeNumber);
  diag->add_option("--motion-estimator", d.motion_estimator,
                   "rts: Rauch-Tung-Striebel smoother, noise from the record (default); central: central differences; "
                   "rts_loop_force: rts, with --reference, and the loop's model also driven by the measured force "
                   "(a servo that yields to friction); rts_jumps: rts, the velocity also let jump where a likelihood-ratio "
                   "test finds it did (a drive that steps its speed within a sample: velocity-step tests; "
                   "docs/identification.md); rts_stretches: with --reference, rts with a jerk intensity of its own "
                   "for each stretch of the setpoint (holds, steady passes, ramps) and no loop model; auto: with "
                   "--reference, rts or rts_stretches, whichever lets the base LuGre fit predict the measured force "
                   "better on the held-out passes (both figures in the JSON's input.motion_evidence)")
      ->check(CLI::IsMember({"rts", "central", "rts_loop_force", "rts_jumps", "rts_stretches", "auto"}))->capture_default_str();
  diag->add_option("--effects", d.effects, "comma-separated candidates (default: all)");
  diag->add_option("--base-model", d.base_model,
                   "lugre: the LuGre base (default); choose: LuGre, + elasto-plastic presliding, + rate-and-state, "
                   "kept on held-out data")
      ->check(CLI::IsMember({"lugre", "choose"}))->capture_default_str();
  diag->add_option("--dither", d.dither,
                   "off: the base model's bristle relaxes at the resolved speed (default); on: at E|v + d|, d the "
                   "tip's unresolved dither of fitted RMS dither_speed (a closed loop that feeds its sensor noise "
                   "back); choose: fitted both ways, the dither kept where it predicts the held-out passes better "
                   "(JSON base_model.dither_choice)")
      ->check(CLI::IsMember({"off", "on", "choose"}))->capture_default_str();
  diag->add_option("--min-confusion-z", d.min_confusion_z,
                   "refuse an accepted effect whose nearest rival leaves less than Z of it (the confusion check; 0: "
                   "reported only, the default)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  diag->add_option("--begin", d.begin, "analyse only samples with t >= begin (s)");
  diag->add_option("--end", d.end, "analyse only samples with t <= end (s)");
  diag->add_flag("--json", d.json, "print one JSON object (fields: see README)");
  diag->add_flag("--timings", d.timings,
                 "write each phase's wall and CPU time, model work (Jacobian rows x columns) and peak memory to "
                 "stderr, one 'timings:' line per phase");
  diag->add_option("--out", d.out, "also write DIR/diagnosis.json, traces.csv and signatures.csv (plots: analysis/plot_diagnosis.py DIR)");

  StribeckArgs s;
  auto* strib = app.add_subcommand("stribeck", "steady-state curve fit (LuGre or eq. 44)");
  strib->footer(kStribeckFooter);
  strib->add_option("FILE", s.file, "CSV file with a header line")->required()->check(CLI::ExistingFile);
  strib->add_option("--x", s.x, "column of the speed (or other abscissa)")->required();
  strib->add_option("--y", s.y, "column of the force (or mu)")->required();
  strib->add_option("--weight", s.weight, "column of point weights");
  strib->add_option("--model", s.model, "lugre or eq44")->check(CLI::IsMember({"lugre", "eq44"}))->capture_default_str();
  strib->add_option("--stribeck-exponent", s.stribeck_exponent, "Stribeck exponent D")->capture_default_str();
  strib->add_flag("--no-offset", s.no_offset, "no offset term");
  strib->add_flag("--json", s.json, "print one JSON object");
  strib->add_flag("--diagnose", s.diagnose,
                  "effect report: base model and candidate effects (direction_asymmetry, velocity_strengthening, "
                  "load_dependence) decided on held-out points; --x is the signed velocity (m/s), --y the friction force (N)");
  strib->add_option("--load", s.load, "column of the normal load (N), with --diagnose: levels scale with the load");

  MetricsArgs m;
  auto* metrics = app.add_subcommand("metrics", "scratch metrics of a recorded tribo run");
  metrics->footer(kMetricsFooter);
  metrics->add_option("RUN_DIR", m.run_dir, "a tribo run directory")->required();
  metrics->add_flag("--json", m.json, "print SI units as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return usage_error(e.what());
  }
  if (diag->parsed()) return diagnose_command(d);
  if (strib->parsed()) return stribeck_command(s);
  if (metrics->parsed()) return metrics_command(m);
  return usage_error("missing command");
}
