#include "analysis/report/diagnosis_report.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>

#include <fmt/printf.h>
#include <nlohmann/json.hpp>

namespace tribo::analysis {

namespace {

// An option's held-out error beside the chosen contact's, in standard errors
// of the difference over the held-out blocks. Below the chosen: better, yet
// past a bound or not better by the gain a richer contact must show.
std::string contact_excess_text(bool chosen, double excess_se) {
  if (chosen) return " (chosen)";
  if (!std::isfinite(excess_se)) return " (one held-out block: no standard error against the chosen)";
  return fmt::sprintf(" (%.2f standard errors %s the chosen)", std::fabs(excess_se), excess_se < 0 ? "below" : "above");
}

using Json = nlohmann::ordered_json;

Json parameters_json(const std::vector<ParamEstimate>& params) {
  Json out = Json::array();
  for (const auto& p : params) {
    out.push_back({{"name", p.name}, {"value", p.value}, {"std_error", p.std_error}, {"unit", p.unit},
                   {"determined", p.determined}, {"fixed", p.fixed}});
    if (!std::isnan(p.motion_systematic)) out.back()["motion_systematic"] = p.motion_systematic;
  }
  return out;
}

Json errors_json(const ErrorStats& e) {
  return {{"n", e.n}, {"rms", e.rms}, {"nrmse", e.nrmse}, {"max", e.max_abs}, {"relative", e.relative}};
}

Json model_errors_json(const ModelErrors& e) {
  return {{"fit", errors_json(e.fit)}, {"heldout", errors_json(e.heldout)}, {"all", errors_json(e.all)}};
}

void add_trial(Json& j, const CandidateTrial& t) {
  j["signature"] = t.signature.summary;
  j["signature_strength"] = t.signature.strength;
  j["delta_aicc"] = t.delta_aicc;
  j["delta_aicc_effective"] = t.delta_aicc_effective;
  j["heldout_rms_before"] = t.heldout_rms_before;
  j["heldout_rms_after"] = t.heldout_rms_after;
  j["heldout_gain"] = t.heldout_gain;
  j["block_agreement"] = t.block_agreement;
  j["round"] = t.round;
}

std::string number(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, ec == std::errc() ? end : buf);
}

std::string csv_text(std::string s) {
  for (char& c : s) {
    if (c == ',' || c == '\n') c = ';';
  }
  return s;
}

std::string strengths_text(const std::vector<double>& strengths) {
  std::string text;
  for (std::size_t k = 0; k < strengths.size(); ++k) {
    text += (k == 0 ? "" : k + 1 == strengths.size() ? " and " : ", ") + fmt::sprintf("%.3g", strengths[k]);
  }
  return text;
}

Json finite_or_null(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json confusion_json(const EffectConfusion& c) {
  Json rivals = Json::array();
  for (const RivalConfusion& r : c.rivals) {
    rivals.push_back({{"name", effect_name(r.rival)}, {"z", finite_or_null(r.z)}, {"explained", finite_or_null(r.explained)}});
  }
  const RivalConfusion* nearest = c.rivals.empty() ? nullptr : &c.rivals.front();
  return {{"nearest", nearest ? Json(effect_name(nearest->rival)) : Json(nullptr)},
          {"z", nearest ? finite_or_null(nearest->z) : Json(nullptr)},
          {"explained", nearest ? finite_or_null(nearest->explained) : Json(nullptr)},
          {"z_alone", finite_or_null(c.z_alone)},
          {"z_needed", c.z_needed},
          {"distinguishable", c.distinguishable()},
          {"rivals", std::move(rivals)}};
}

// The motion estimates weighed by the base fit's held-out force error, or
// null (none weighed).
Json motion_evidence_json(const std::vector<MotionModelEvidence>& evidence) {
  if (evidence.empty()) return Json(nullptr);
  Json models = Json::array();
  for (const MotionModelEvidence& e : evidence) {
    models.push_back({{"estimator", e.estimator},
                      {"heldout_pass_rms", finite_or_null(e.heldout_pass_rms)},
                      {"state_from_rest", e.state_from_rest},
                      {"heldout_excess_se", finite_or_null(e.heldout_excess_se)},
                      {"chosen", e.chosen}});
  }
  return {{"criterion", "the base fit's RMS force error over the held-out pass samples (force units); the setpoint's "
                        "stretches replace the loop model when 2 % lower and at least one standard error of the "
                        "difference over the held-out passes"},
          {"heldout_samples", evidence.front().heldout_samples},
          {"models", models}};
}

}  // namespace

std::string confusion_text(const EffectConfusion& c) {
  if (c.rivals.empty() || std::isnan(c.rivals.front().z)) {
    return fmt::sprintf("no rival applies to this record (its visible part alone at z = %.1f)", c.z_alone);
  }
  const RivalConfusion& n = c.rivals.front();
  const std::string name(effect_name(n.rival));
  if (c.distinguishable()) {
    return fmt::sprintf("distinguishable from its nearest rival %s at z = %.1f (%s takes up %.0f %% of its visible part; z = %.1f alone)",
                        name.c_str(), n.z, name.c_str(), 100 * n.explained, c.z_alone);
  }
  return fmt::sprintf("not distinguishable from %s at this record's noise: z = %.1f below %.1f (%s takes up %.0f %% of its "
                      "visible part; z = %.1f alone)",
                      name.c_str(), n.z, c.z_needed, name.c_str(), 100 * n.explained, c.z_alone);
}

std::string diagnosis_json(const MeasuredSeries& s, const Diagnosis& d, const ReportInfo& info) {
  Json j;
  j["tool"] = "tribo-fit diagnose";
  j["input"] = {{"source", s.source},
                {"samples", s.size()},
                {"duration_s", s.time_s.back() - s.time_s.front()},
                {"force_unit", s.force_unit},
                {"normal_channel", s.has_normal()},
                {"velocity", s.velocity_measured ? "measured" : "derived from position"},
                {"acceleration", s.acceleration_measured ? "measured" : "derived from velocity"},
                {"motion_estimator", s.motion_estimator},
                {"position_noise_m", s.position_noise_m},
                {"position_resolution_m", s.position_resolution_m},
                {"velocity_noise_m_per_s", s.velocity_noise_m_per_s},
                {"velocity_jumps", s.velocity_jumps},
                {"velocity_jumps_force_did_not_follow", s.velocity_jumps_force_did_not_follow},
                {"loop_taps", s.loop_taps},
                {"loop_variance_explained", s.loop_variance_explained},
                {"loop_force_taps", s.loop_force_taps},
                {"loop_force_response_m_per_n", s.loop_force_response_m_per_n},
                {"motion_evidence", motion_evidence_json(s.motion_evidence)},
                {"command", info.command_line}};
  j["segmentation"] = {{"passes", d.motion.passes.size()},
                       {"holds", d.motion.holds.size()},
                       {"heldout_scheme", d.motion.heldout_scheme},
                       {"fit_samples", d.before.fit.n},
                       {"heldout_samples", d.before.heldout.n}};
  const ModelStructure& st = d.base.result.params.structure;
  j["base_model"] = {{"name", "lugre"},
                     {"load_scaled", st.load_scaled},
                     {"fit_mass", st.fit_mass},
                     {"stribeck_exponent", st.stribeck_exponent},
                     {"state_from_rest", st.state_from_rest},
                     {"parameters", parameters_json(d.base.result.estimates)},
                     {"starts_evaluated", d.base.starts_evaluated},
                     {"starts_refined", d.base.starts_refined},
                     {"converged", d.base.result.converged},
                     {"warnings", d.base.result.warnings},
                     {"describes_record", d.adequacy.describes_record},
                     {"not_describing_reasons", d.adequacy.reasons}};
  if (d.base_contact) {
    Json options = Json::array();
    for (const auto& o : d.base_contact->options) {
      Json option = {{"name", o.name},
                     {"heldout_rms", o.heldout_rms},
                     {"free_parameters", o.free_parameters},
                     {"heldout_excess_se", std::isfinite(o.heldout_excess_se) ? Json(o.heldout_excess_se) : Json(nullptr)},
                     {"parameters", parameters_json(o.parameters)}};
      if (!o.note.empty()) option["note"] = o.note;
      options.push_back(std::move(option));
    }
    j["base_model"]["contact_choice"] = {{"chosen", d.base_contact->chosen}, {"options", std::move(options)}};
    if (!d.base_contact->not_tried.empty()) j["base_model"]["contact_choice"]["not_tried"] = d.base_contact->not_tried;
    if (!d.base_contact->left_model.empty()) j["base_model"]["contact_choice"]["left_model"] = d.base_contact->left_model;
  }
  if (d.dither) {
    const DitherChoice& c = *d.dither;
    j["base_model"]["dither_choice"] = {
        {"chosen", c.chosen},
        {"criterion", "kept when within its bounds and it lowers the held-out RMS by 2 % and by 1 standard error "
                      "of the difference over the held-out blocks"},
        {"heldout_rms_without", c.heldout_rms_without},
        {"heldout_rms_with", c.heldout_rms_with},
        {"excess_se_without", std::isfinite(c.excess_se_without) ? Json(c.excess_se_without) : Json(nullptr)},
        {"dither_speed_m_per_s", c.dither_speed_m_per_s},
        {"dither_speed_std_error", std::isfinite(c.dither_speed_se) ? Json(c.dither_speed_se) : Json(nullptr)}};
    if (!c.objection.empty()) j["base_model"]["dither_choice"]["not_physical"] = c.objection;
  }
  if (d.pass_start) {
    j["base_model"]["pass_start_state"] = {
        {"chosen", d.pass_start->state_from_rest ? "from the force at rest" : "modelled through the holds"},
        {"heldout_pass_rms_modelled_holds", d.pass_start->heldout_rms_modelled_holds},
        {"heldout_pass_rms_state_from_rest", d.pass_start->heldout_rms_state_from_rest},
        {"final_heldout_pass_rms_modelled_holds", d.pass_start->final_heldout_rms_modelled_holds},
        {"final_heldout_pass_rms_state_from_rest", d.pass_start->final_heldout_rms_state_from_rest}};
    if (!d.pass_start->objection.empty()) j["base_model"]["pass_start_state"]["other_not_physical"] = d.pass_start->objection;
  }
  if (d.drift_knots) {
    Json tried = Json::array();
    for (const auto& [k, rms] : d.drift_knots->cv_rms) tried.push_back({{"intervals", k}, {"cv_rms", rms}});
    j["drift_knots"] = {{"intervals", d.drift_knots->intervals},
                        {"default_intervals", d.drift_knots->default_intervals},
                        {"chosen_by", "leave-one-fitted-pass-out cross-validation of the base residual"},
                        {"tried", std::move(tried)}};
  }

  if (d.creep) {
    const CreepInHolds& c = *d.creep;
    Json holds = Json::array();
    for (const auto& h : c.holds) {
      holds.push_back({{"start_s", h.start_s}, {"duration_s", h.duration_s}, {"mean_force", h.mean_force},
                       {"slope_per_s", h.slope_per_s}, {"slope_std_error", h.slope_std_error},
                       {"levels_off", h.levels_off}});
    }
    auto number = [](double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); };
    const char* form = c.form == HoldDriftForm::kCreep             ? "creep under a stuck contact"
                       : c.form == HoldDriftForm::kReading         ? "drift of the force reading"
                       : c.form == HoldDriftForm::kCreepAndReading ? "creep and a drift of the force reading"
                                                                   : nullptr;
    j["creep_in_holds"] = {{"accepted", c.accepted},
                           {"form", form ? Json(form) : Json(nullptr)},
                           {"verdict", c.verdict},
                           {"holds", std::move(holds)},
                           {"creep_rate_per_s", c.creep_rate_per_s},
                           {"creep_rate_std_error", c.creep_rate_std_error},
                           {"drain_per_s", c.drain_per_s},
                           {"drain_std_error", c.drain_std_error},
                           {"creep_model", c.creep_model},
                           {"creep_trend_per_s", c.creep_trend_per_s},
                           {"creep_trend_std_error", c.creep_trend_std_error},
                           {"strength_z", c.strength_z},
                           {"reading_share", number(c.reading_share)},
                           {"reading_share_std_error", number(c.reading_share_std_error)},
                           {"reading_rate_per_s", number(c.reading_rate_per_s)},
                           {"reading_rate_std_error", number(c.reading_rate_std_error)},
                           {"creep_part_per_s", number(c.creep_part_per_s)},
                           {"creep_part_std_error", number(c.creep_part_std_error)},
                           {"stiffness_per_m", number(c.stiffness_per_m)},
                           {"stiffness_std_error", c.stiffness_std_error},
                           {"stiffness_source", c.stiffness_source},
                           {"creep_speed_m_per_s", number(c.creep_speed_m_per_s)},
                           {"creep_speed_std_error", number(c.creep_speed_std_error)},
                           {"levelling_holds", c.levelling_holds},
                           {"speed_holds", c.speed_holds},
                           {"heldout_rms_before", c.heldout_rms_before},
                           {"heldout_rms_after", c.heldout_rms_after},
                           {"heldout_gain", c.heldout_gain},
                           {"block_agreement", c.block_agreement}};
  } else {
    j["creep_in_holds"] = nullptr;
  }

  Json& accepted = j["accepted_effects"] = Json::array();
  for (const auto& a : d.accepted) {
    Json effect = {{"name", effect_name(a.effect)}, {"parameters", parameters_json(a.parameters)}};
    add_trial(effect, a.trial);
    if (const auto& c = a.confusion) effect["confusion"] = confusion_json(*c);
    accepted.push_back(std::move(effect));
  }
  Json& rejected = j["rejected_effects"] = Json::array();
  for (const auto& r : d.rejected) {
    Json effect = {{"name", effect_name(r.effect)}, {"reason", r.reason}, {"signature_strength", r.signature_strength}};
    if (r.last_trial) {
      effect["delta_aicc"] = r.last_trial->delta_aicc;
      effect["delta_aicc_effective"] = r.last_trial->delta_aicc_effective;
      effect["heldout_gain"] = r.last_trial->heldout_gain;
      effect["block_agreement"] = r.last_trial->block_agreement;
    }
    if (const auto& m = r.minimum_detectable) {
      effect["minimum_detectable"] = {{"parameter", m->parameter},
                                      {"unit", m->unit},
                                      {"value", std::isfinite(m->value) ? Json(m->value) : Json(nullptr)},
                                      {"searched_up_to", m->searched_up_to},
                                      {"axis", m->axis},
                                      {"detection_probability", m->detection_probability},
                                      {"bound_by", m->from_rediagnosis    ? "injection and rediagnosis"
                                                   : m->from_injection    ? "injection and recovery"
                                                   : m->from_fitted_error ? "the candidate's fitted standard error"
                                                                          : "the linearised gates"},
                                      {"injected_strength", std::isfinite(m->injected_strength) ? Json(m->injected_strength) : Json(nullptr)},
                                      {"recovered_share", std::isfinite(m->recovered_share) ? Json(m->recovered_share) : Json(nullptr)},
                                      {"withheld", m->withheld.empty() ? Json(nullptr) : Json(m->withheld)},
                                      {"rediagnosed_at", m->rediagnosed_at}};
    }
    rejected.push_back(std::move(effect));
  }

  j["error_before"] = model_errors_json(d.before);
  j["error_after"] = model_errors_json(d.after);
  Json& by_condition = j["heldout_by_condition"] = Json::array();
  for (const auto& c : d.heldout_by_condition) {
    by_condition.push_back({{"condition", c.condition}, {"n", c.n}, {"rms_before", c.rms_before}, {"rms_after", c.rms_after}});
  }

  Json& final_model = j["final_model"];
  final_model["effects"] = Json::array();
  for (Effect e : d.final_fit.params.structure.effects) final_model["effects"].push_back(effect_name(e));
  if (d.final_fit.params.structure.has(Effect::kRateState)) {
    final_model["rate_state_law"] = d.final_fit.params.structure.rate_state_slip_law ? "slip (Ruina)" : "ageing (Dieterich)";
  }
  final_model["parameters"] = parameters_json(d.final_fit.estimates);
  final_model["warnings"] = d.final_fit.warnings;
  // What the model's terms are referred to, for users that evaluate it
  // elsewhere (the friction compensation): the record's, as the fit took them.
  const ModelData references(s, d.motion);
  final_model["reference_speed_m_per_s"] = references.speed_ref;
  final_model["reference_load"] = s.has_normal() ? Json(references.normal_ref) : Json(nullptr);

  j["unexplained"] = d.unexplained ? Json(*d.unexplained) : Json(nullptr);
  j["noise_floor"] = d.noise_floor;
  j["warnings"] = d.warnings;
  j["elapsed_s"] = info.elapsed_s;
  return j.dump(2) + "\n";
}

std::string minimum_detectable_text(const DetectableStrength& m) {
  if (!m.withheld.empty()) return "minimum detectable strength not given: " + m.withheld;
  const std::string recovered = m.from_injection ? fmt::sprintf("; injected into the record at %.3g, a refit found %.0f %% of it",
                                                                m.injected_strength, 100 * m.recovered_share)
                                                  : "";
  if (!std::isfinite(m.value) && m.from_rediagnosis) {
    return fmt::sprintf("not identifiable from this record: %s injected at %s %s and the record diagnosed again for it, "
                        "the final model refitted without it, never accepted",
                        m.parameter, strengths_text(m.rediagnosed_at), m.unit);
  }
  if (!std::isfinite(m.value) && m.from_injection) {
    return fmt::sprintf("not identifiable from this record: %s injected at %.3g %s, a refit found %.0f %% of it", m.parameter,
                        m.injected_strength, m.unit, 100 * m.recovered_share);
  }
  if (!std::isfinite(m.value)) {
    return fmt::sprintf("not identifiable from this record at any %s up to %.3g %s", m.parameter, m.searched_up_to, m.unit);
  }
  std::string rediagnosed;
  if (m.from_rediagnosis) {
    rediagnosed = fmt::sprintf("; injected at %s and the record diagnosed again for it, the final model refitted without "
                               "it: accepted first at %.3g", strengths_text(m.rediagnosed_at), m.value);
  } else if (!m.rediagnosed_at.empty()) {  // accepted at the figure itself
    rediagnosed = "; injected there and the record diagnosed again for it: accepted";
  }
  return fmt::sprintf("not reliably identifiable from this record below %s = %.3g %s (minimum detectable strength: found "
                      "with %.0f %% probability there; %s%s%s%s)",
                      m.parameter, m.value, m.unit, 100 * m.detection_probability, m.axis,
                      m.from_fitted_error && !m.from_injection && !m.from_rediagnosis ? "; from the candidate's fitted standard error"
                                                                                      : "",
                      m.from_rediagnosis ? "" : recovered, rediagnosed);
}

std::string diagnosis_text(const MeasuredSeries& s, const Diagnosis& d) {
  std::string out;
  auto line = [&](const char* format, auto... args) {
    out += fmt::sprintf(format, args...);
    out += '\n';
  };
  line("%s: %zu samples, %zu passes, %zu holds; held out: %s", s.source.c_str(), s.size(), d.motion.passes.size(),
       d.motion.holds.size(), d.motion.heldout_scheme.c_str());
  line("motion: velocity %s (estimator %s); position noise floor %.3g m, resolution %.3g m, velocity noise %.3g m/s",
       s.velocity_measured ? "measured" : "derived", s.motion_estimator.c_str(), s.position_noise_m,
       s.position_resolution_m, s.velocity_noise_m_per_s);
  if (s.motion_estimator.find("with_velocity_jumps") != std::string::npos) {
    line("  the velocity let jump at %d samples (a likelihood-ratio test at 1 %% over the record; %d more the force did not follow, not taken)",
         s.velocity_jumps, s.velocity_jumps_force_did_not_follow);
  }
  for (const MotionModelEvidence& e : s.motion_evidence) {
    line("  weighed: %s, the base fit's held-out pass RMS %.4g %s over %zu samples (each pass starting %s), %s",
         e.estimator.c_str(), e.heldout_pass_rms, s.force_unit.c_str(), e.heldout_samples,
         e.state_from_rest ? "from the force at rest" : "modelled through the holds",
         e.chosen ? "chosen" : fmt::sprintf("%.2f standard errors above the chosen", e.heldout_excess_se).c_str());
  }
  if (s.loop_taps > 0) {
    line("  reference through the fitted loop response (%d taps; explains %.6f of the position's variance)", s.loop_taps,
         s.loop_variance_explained);
    if (s.loop_force_taps > 0) {
      line("  and the friction force through %d taps: %.3g m of position per N of force", s.loop_force_taps,
           s.loop_force_response_m_per_n);
    }
  }
  line("base model (LuGre):");
  if (d.pass_start) {
    line("  each pass starts %s (the record diagnosed both ways; held-out pass RMS of the final model %.4g with the "
         "holds modelled, %.4g from the force at rest; of the base fit %.4g and %.4g)",
         d.pass_start->state_from_rest ? "from the force at rest" : "from the state modelled through the holds",
         d.pass_start->final_heldout_rms_modelled_holds, d.pass_start->final_heldout_rms_state_from_rest,
         d.pass_start->heldout_rms_modelled_holds, d.pass_start->heldout_rms_state_from_rest);
    if (!d.pass_start->objection.empty()) line("    the other start's final base is not physical: %s", d.pass_start->objection.c_str());
  }
  if (d.dither) {
    const DitherChoice& c = *d.dither;
    line("  unresolved dither %s: held-out RMS %.4g without, %.4g with (%.2g standard errors), dither_speed %.3g m/s%s%s",
         c.chosen ? "kept" : "not kept", c.heldout_rms_without, c.heldout_rms_with, c.excess_se_without, c.dither_speed_m_per_s,
         c.objection.empty() ? "" : "; not physical: ", c.objection.c_str());
  }
  if (d.base_contact) {
    line("  contact law chosen on held-out data: %s%s%s", d.base_contact->chosen.c_str(),
         d.base_contact->not_tried.empty() ? "" : "; ", d.base_contact->not_tried.c_str());
    for (const auto& o : d.base_contact->options) {
      const std::string excess = contact_excess_text(o.name == d.base_contact->chosen, o.heldout_excess_se);
      line("    %-34s held-out RMS %.4g%s, %d free parameters%s%s", o.name.c_str(), o.heldout_rms, excess.c_str(), o.free_parameters,
           o.note.empty() ? "" : "; ", o.note.c_str());
      std::string laws;
      for (const auto& p : o.parameters) {
        if (!p.effect) continue;
        // With its error, so that a law kept on its held-out error shows how
        // well the record determines it beside the others tried.
        laws += std::isfinite(p.std_error) && !p.fixed ? fmt::sprintf("%s %.4g +- %.2g %s, ", p.name, p.value, p.std_error, p.unit)
                                                      : fmt::sprintf("%s %.4g %s, ", p.name, p.value, p.unit);
      }
      if (!laws.empty()) line("      %s", laws.substr(0, laws.size() - 2).c_str());
    }
    if (!d.base_contact->left_model.empty()) line("    %s", d.base_contact->left_model.c_str());
  }
  for (const auto& p : d.base.result.estimates) {
    line("  %-20s %12.5g +- %-10.3g %s%s", p.name.c_str(), p.value, p.std_error, p.unit.c_str(), p.determined ? "" : "  (not determined)");
  }
  if (d.drift_knots) {
    line("drift candidate's spline: %d knot intervals, chosen by cross-validation over the fitted passes (default %d)",
         d.drift_knots->intervals, d.drift_knots->default_intervals);
  }
  for (const auto& a : d.accepted) {
    line("accepted %s: %s", std::string(effect_name(a.effect)).c_str(), a.trial.verdict.c_str());
    line("  signature: %s", a.trial.signature.summary.c_str());
    for (const auto& p : a.parameters) line("  %-20s %12.5g +- %-10.3g %s", p.name.c_str(), p.value, p.std_error, p.unit.c_str());
    if (a.confusion) line("  %s", confusion_text(*a.confusion).c_str());
  }
  for (const auto& r : d.rejected) {
    line("rejected %s: %s", std::string(effect_name(r.effect)).c_str(), r.reason.c_str());
    if (const auto& m = r.minimum_detectable) line("  %s", minimum_detectable_text(*m).c_str());
  }
  auto err = [&](const char* label, const ModelErrors& e) {
    line("%s fit RMS %.4g (NRMSE %.4f, max %.4g, relative %.2f %%), held-out RMS %.4g (NRMSE %.4f, max %.4g, relative %.2f %%)", label,
         e.fit.rms, e.fit.nrmse, e.fit.max_abs, 100 * e.fit.relative, e.heldout.rms, e.heldout.nrmse, e.heldout.max_abs,
         100 * e.heldout.relative);
  };
  err("before:", d.before);
  err("after: ", d.after);
  const std::string contact = d.base_contact ? "contact " + d.base_contact->chosen : "LuGre";
  line("final model (%s%s):", contact.c_str(), d.accepted.empty() ? ", no effect accepted" : " with the accepted effects");
  for (const auto& p : d.final_fit.estimates) {
    const std::string motion = std::isnan(p.motion_systematic) ? "" : fmt::sprintf("  (of which motion model %.3g)", p.motion_systematic);
    line("  %-20s %12.5g +- %-10.3g %s%s%s%s", p.name.c_str(), p.value, p.std_error, p.unit.c_str(), p.fixed ? "  (held)" : "",
         p.determined || p.fixed ? "" : "  (not determined)", motion.c_str());
  }
  line("unexplained: %s", d.unexplained ? d.unexplained->c_str() : "none (residual at the white-noise floor)");
  // Every warning, as in the JSON (base fit, final fit, diagnosis), once.
  std::vector<std::string> warnings;
  for (const auto* list : {&d.base.result.warnings, &d.final_fit.warnings, &d.warnings}) {
    for (const auto& w : *list) {
      if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
    }
  }
  for (const auto& w : warnings) out += "warning: " + w + "\n";
  return out;
}

bool write_diagnosis_files(const std::filesystem::path& dir, const MeasuredSeries& s, const Diagnosis& d,
                           const std::string& json, std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    error = "cannot create " + dir.string() + ": " + ec.message();
    return false;
  }
  {
    std::ofstream out(dir / "diagnosis.json");
    out << json;
    if (!out) {
      error = "cannot write " + (dir / "diagnosis.json").string();
      return false;
    }
  }
  {
    std::ofstream out(dir / "traces.csv");
    out << "t_s,position_m,velocity_m_per_s,force,model_before,model_after,heldout,direction,distance_since_start_m\n";
    for (std::size_t i = 0; i < s.size(); ++i) {
      out << number(s.time_s[i]) << ',' << number(s.position_m[i]) << ',' << number(s.velocity_m_per_s[i]) << ','
          << number(s.force_n[i]) << ',' << number(d.model_before[i]) << ',' << number(d.model_after[i]) << ','
          << static_cast<int>(d.motion.heldout[i]) << ',' << d.motion.direction[i] << ','
          << number(d.motion.distance_since_start_m[i]) << '\n';
    }
    if (!out) {
      error = "cannot write " + (dir / "traces.csv").string();
      return false;
    }
  }
  {
    std::ofstream out(dir / "signatures.csv");
    out << "effect,stage,x_label,y_label,x,y,y_error\n";
    auto write = [&](const Signature& sig, const char* stage) {
      for (std::size_t k = 0; k < sig.plot.x.size(); ++k) {
        out << effect_name(sig.effect) << ',' << stage << ',' << csv_text(sig.plot.x_label) << ',' << csv_text(sig.plot.y_label)
            << ',' << number(sig.plot.x[k]) << ',' << number(sig.plot.y[k]) << ','
            << (k < sig.plot.y_error.size() ? number(sig.plot.y_error[k]) : "") << '\n';
      }
    };
    for (const auto& a : d.accepted) write(a.trial.signature, "accepted");
    for (const auto& r : d.rejected) {
      if (r.last_trial) write(r.last_trial->signature, "rejected");
    }
    if (!out) {
      error = "cannot write " + (dir / "signatures.csv").string();
      return false;
    }
  }
  return true;
}

}  // namespace tribo::analysis
