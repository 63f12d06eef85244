#include "analysis/fit_commands.h"

#include <chrono>
#include <exception>
#include <optional>

#include <nlohmann/json.hpp>

#include "analysis/report/diagnosis_report.h"
#include "analysis/parallel_for.h"
#include "analysis/metrics/scratch_metrics.h"
#include "analysis/motion/motion_estimate.h"

namespace tribo::analysis {

std::string metrics_json(const v1::SampleBlock& samples) {
  using Json = nlohmann::ordered_json;
  Json j;
  Json& scratches = j["scratches"] = Json::array();
  for (const auto& s : scratch_identification(samples)) {
    const auto& m = s.metrics;
    scratches.push_back({{"segment", static_cast<int>(m.segment)},
                         {"velocity_m_per_s", m.velocity_m_per_s},
                         {"normal_force_n", m.normal_force_n},
                         {"mean_friction_n", m.mean_friction_n},
                         {"mu", m.mu},
                         {"stiction_peak_n", m.stiction_peak_n},
                         {"stretch_time_s", s.stretch_time_s},
                         {"stretch_distance_m", s.stretch_distance_m},
                         {"steady_lag_m", m.steady_lag_m},
                         {"contact_stiffness_n_per_m", s.gains.contact_stiffness_n_per_m},
                         {"mki_n_per_m_s", s.gains.integral_gain},
                         {"mk_n_per_m", s.gains.proportional_gain}});
  }
  const auto drift = lateral_drift_from_holds(samples);
  Json holds = Json::array();
  for (const auto& h : drift.holds) {
    holds.push_back({{"segment", static_cast<int>(h.segment)},
                     {"duration_s", h.duration_s},
                     {"rate_n_per_s", h.rate_n_per_s},
                     {"rate_std_error", h.rate_std_error}});
  }
  j["drift"] = {{"mean_rate_n_per_s", drift.mean_rate_n_per_s}, {"holds", std::move(holds)}};
  const auto tilt = fit_surface_tilt(samples);
  j["tilt"] = tilt ? Json{{"segment", static_cast<int>(tilt->segment)}, {"slope", tilt->slope}, {"samples", tilt->samples}}
                   : Json(nullptr);
  return j.dump(2) + "\n";
}

namespace {

// --motion-estimator auto: the loop model's estimate (series, the default)
// or the setpoint stretches', as weigh_motion_estimates chooses on the base
// fit's held-out force error, becomes the series' motion; both estimates'
// figures go to series.motion_evidence, the loop model's first.
void keep_motion_by_heldout_force(MeasuredSeries& series, MeasuredSeries& stretches, const DiagnosisOptions& options) {
  std::vector<MotionModelEvidence> evidence = weigh_motion_estimates({&series, &stretches}, options);
  const bool take_stretches = evidence[1].chosen;
  const std::string other = evidence[take_stretches ? 0 : 1].estimator;
  if (take_stretches) series = std::move(stretches);
  series.motion_estimator += ", chosen on held-out force over " + other;
  series.motion_evidence = std::move(evidence);
}

}  // namespace

DiagnoseOutcome diagnose_series(MeasuredSeries series, const DiagnoseRequest& r) {
  DiagnoseOutcome out;
  if (r.begin_s > -HUGE_VAL || r.end_s < HUGE_VAL) {
    std::size_t first = 0, last = series.size();
    while (first < series.size() && series.time_s[first] < r.begin_s) ++first;
    while (last > first && series.time_s[last - 1] > r.end_s) --last;
    series = slice(series, first, last);
  }
  if (const std::string problem = check_series(series); !problem.empty()) {
    out.error = series.source + ": " + problem;
    return out;
  }
  // With a reference and the force, the loop model with and without the
  // servo's yield to the force are both defensible motion models: the other
  // one (and the setpoint's stretches, below) serves the parameters'
  // motion-model systematic error.
  std::optional<MeasuredSeries> alternative;
  const bool smoothed = !(r.smooth_s > 0 || r.central_differences);
  if (smoothed && !series.reference_m.empty() && series.velocity_m_per_s.empty()) alternative = series;
  // The setpoint's stretches: with --motion-estimator auto beside the loop
  // model without the force, one of the two kept below; otherwise a further
  // alternative for the motion-model systematic error.
  std::optional<MeasuredSeries> stretches;
  if (alternative) stretches = series;
  const bool loop_force = r.loop_force && !r.motion_by_heldout_force;
  const ReferenceMotion reference_motion = r.motion_by_heldout_force ? ReferenceMotion::loop_model : r.reference_motion;
  if (!smoothed) {
    derive_motion(series, r.smooth_s);
  } else {
    // The estimates are independent (one per core) but for their loop
    // models' normal equations, formed once on every core.
    std::optional<Eigen::MatrixXd> gram;
    if (alternative) gram = loop_normal_matrix(series.time_s, series.reference_m, series.force_n, 0);
    const Eigen::MatrixXd* shared = gram ? &*gram : nullptr;
    parallel_for(stretches ? 3 : alternative ? 2 : 1, 0, [&](std::size_t k) {
      if (k == 0) derive_motion_smoothed(series, loop_force, r.velocity_jumps, shared, reference_motion);
      else if (k == 1) derive_motion_smoothed(*alternative, !loop_force, r.velocity_jumps, shared);
      else derive_motion_smoothed(*stretches, false, false, nullptr, ReferenceMotion::setpoint_stretches);
    });
  }
  mark_phase(r.timings, "motion estimates");
  if (alternative && alternative->loop_taps == 0) alternative.reset();
  if (alternative) keep_motion_only(*alternative);
  if (!alternative) stretches.reset();
  if (stretches && !r.motion_by_heldout_force) keep_motion_only(*stretches);

  DiagnosisOptions options;
  options.base.fit_mass = r.fit_mass;
  options.base.load_scaled = series.has_normal() && r.load_scaling;
  options.base.stribeck_exponent = r.stribeck_exponent;
  // Holds are where the command stands still whenever it is known (a tribo
  // run, or a CSV with --reference): a velocity estimated from a noisy
  // position starts passes early and finds passes inside long holds.
  options.segmentation.segment_by_reference = r.tribo_run || !series.reference_m.empty();
  options.base.state_from_rest = r.tribo_run;
  options.choose_state_from_rest = !r.tribo_run;
  options.candidates = r.candidates;
  options.choose_base_contact = r.choose_base_contact;
  options.dither = r.dither;
  options.base.unresolved_dither = r.dither == DitherTerm::on;
  options.min_confusion_z = r.min_confusion_z;
  options.timings = r.timings;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    if (stretches && r.motion_by_heldout_force) {
      keep_motion_by_heldout_force(series, *stretches, options);
      stretches.reset();
    }
    if (alternative && series.loop_taps > 0) {
      options.alternative_motions.push_back(&*alternative);
      if (stretches) options.alternative_motions.push_back(&*stretches);
      options.alternative_motions_done = [&] {
        alternative.reset();
        stretches.reset();
      };
    }
    out.diagnosis = diagnose(series, options);
  } catch (const std::exception& e) {
    out.error = std::string("the analysis failed: ") + e.what();
    return out;
  }
  ReportInfo info;
  info.command_line = r.command_line;
  info.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.json = diagnosis_json(series, out.diagnosis, info);
  out.series = std::move(series);
  return out;
}

}  // namespace tribo::analysis
