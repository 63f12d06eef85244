#include "analysis/diagnosis_report.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "analysis/json_writer.h"

namespace tribo::analysis {

namespace {

void write_parameters(JsonWriter& j, const std::vector<ParamEstimate>& params) {
  j.begin_array();
  for (const auto& p : params) {
    j.begin_object();
    j.field("name", p.name).field("value", p.value).field("std_error", p.std_error).field("unit", p.unit);
    j.field("determined", p.determined).field("fixed", p.fixed);
    j.end_object();
  }
  j.end_array();
}

void write_errors(JsonWriter& j, const ErrorStats& e) {
  j.begin_object();
  j.field("n", e.n).field("rms", e.rms).field("nrmse", e.nrmse).field("max", e.max_abs).field("relative", e.relative);
  j.end_object();
}

void write_model_errors(JsonWriter& j, const ModelErrors& e) {
  j.begin_object();
  j.key("fit");
  write_errors(j, e.fit);
  j.key("heldout");
  write_errors(j, e.heldout);
  j.key("all");
  write_errors(j, e.all);
  j.end_object();
}

void write_strings(JsonWriter& j, const std::vector<std::string>& v) {
  j.begin_array();
  for (const auto& s : v) j.value(s);
  j.end_array();
}

void write_trial(JsonWriter& j, const CandidateTrial& t) {
  j.field("signature", t.signature.summary).field("signature_strength", t.signature.strength);
  j.field("delta_aicc", t.delta_aicc).field("delta_aicc_effective", t.delta_aicc_effective);
  j.field("heldout_rms_before", t.heldout_rms_before);
  j.field("heldout_rms_after", t.heldout_rms_after).field("heldout_gain", t.heldout_gain);
  j.field("block_agreement", t.block_agreement).field("round", t.round);
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

}  // namespace

std::string diagnosis_json(const MeasuredSeries& s, const Diagnosis& d, const ReportInfo& info) {
  JsonWriter j;
  j.begin_object();
  j.field("tool", "tribo-fit diagnose");
  j.key("input").begin_object();
  j.field("source", s.source).field("samples", s.size()).field("duration_s", s.time_s.back() - s.time_s.front());
  j.field("force_unit", s.force_unit).field("normal_channel", s.has_normal());
  j.field("velocity", s.velocity_measured ? "measured" : "derived from position");
  j.field("acceleration", s.acceleration_measured ? "measured" : "derived from velocity");
  j.field("motion_estimator", s.motion_estimator);
  j.field("position_noise_m", s.position_noise_m).field("position_resolution_m", s.position_resolution_m);
  j.field("velocity_noise_m_per_s", s.velocity_noise_m_per_s);
  j.field("loop_taps", s.loop_taps).field("loop_variance_explained", s.loop_variance_explained);
  j.field("command", info.command_line);
  j.end_object();

  j.key("segmentation").begin_object();
  j.field("passes", d.motion.passes.size()).field("holds", d.motion.holds.size());
  j.field("heldout_scheme", d.motion.heldout_scheme)
      .field("fit_samples", d.before.fit.n)
      .field("heldout_samples", d.before.heldout.n);
  j.end_object();

  j.key("base_model").begin_object();
  const ModelStructure& st = d.base.result.params.structure;
  j.field("name", "lugre").field("load_scaled", st.load_scaled).field("fit_mass", st.fit_mass);
  j.field("stribeck_exponent", st.stribeck_exponent);
  j.field("state_from_rest", st.state_from_rest);
  j.key("parameters");
  write_parameters(j, d.base.result.estimates);
  j.field("starts_evaluated", d.base.starts_evaluated).field("starts_refined", d.base.starts_refined);
  j.field("converged", d.base.result.converged);
  j.key("warnings");
  write_strings(j, d.base.result.warnings);
  j.end_object();

  j.key("accepted_effects").begin_array();
  for (const auto& a : d.accepted) {
    j.begin_object();
    j.field("name", effect_name(a.effect));
    j.key("parameters");
    write_parameters(j, a.parameters);
    write_trial(j, a.trial);
    j.end_object();
  }
  j.end_array();

  j.key("rejected_effects").begin_array();
  for (const auto& r : d.rejected) {
    j.begin_object();
    j.field("name", effect_name(r.effect)).field("reason", r.reason).field("signature_strength", r.signature_strength);
    if (r.last_trial) {
      j.field("delta_aicc", r.last_trial->delta_aicc).field("delta_aicc_effective", r.last_trial->delta_aicc_effective);
      j.field("heldout_gain", r.last_trial->heldout_gain);
      j.field("block_agreement", r.last_trial->block_agreement);
    }
    j.end_object();
  }
  j.end_array();

  j.key("error_before");
  write_model_errors(j, d.before);
  j.key("error_after");
  write_model_errors(j, d.after);
  j.key("heldout_by_condition").begin_array();
  for (const auto& c : d.heldout_by_condition) {
    j.begin_object();
    j.field("condition", c.condition).field("n", c.n).field("rms_before", c.rms_before).field("rms_after", c.rms_after);
    j.end_object();
  }
  j.end_array();

  j.key("final_model").begin_object();
  j.key("effects").begin_array();
  for (Effect e : d.final_fit.params.structure.effects) j.value(effect_name(e));
  j.end_array();
  if (d.final_fit.params.structure.has(Effect::kRateState)) {
    j.field("rate_state_law", d.final_fit.params.structure.rate_state_slip_law ? "slip (Ruina)" : "ageing (Dieterich)");
  }
  j.key("parameters");
  write_parameters(j, d.final_fit.estimates);
  j.key("warnings");
  write_strings(j, d.final_fit.warnings);
  j.end_object();

  j.key("unexplained");
  if (d.unexplained) j.value(*d.unexplained);
  else j.null();
  j.field("noise_floor", d.noise_floor);
  j.key("warnings");
  write_strings(j, d.warnings);
  j.field("elapsed_s", info.elapsed_s);
  j.end_object();
  return j.str();
}

std::string diagnosis_text(const MeasuredSeries& s, const Diagnosis& d) {
  std::string out;
  char buf[512];
  auto line = [&](const char* format, auto... args) {
    std::snprintf(buf, sizeof buf, format, args...);
    out += buf;
    out += '\n';
  };
  line("%s: %zu samples, %zu passes, %zu holds; held out: %s", s.source.c_str(), s.size(), d.motion.passes.size(),
       d.motion.holds.size(), d.motion.heldout_scheme.c_str());
  line("motion: velocity %s (estimator %s); position noise floor %.3g m, resolution %.3g m, velocity noise %.3g m/s",
       s.velocity_measured ? "measured" : "derived", s.motion_estimator.c_str(), s.position_noise_m,
       s.position_resolution_m, s.velocity_noise_m_per_s);
  if (s.loop_taps > 0) {
    line("  reference through the fitted loop response (%d taps; explains %.6f of the position's variance)", s.loop_taps,
         s.loop_variance_explained);
  }
  line("base model (LuGre):");
  for (const auto& p : d.base.result.estimates) {
    line("  %-20s %12.5g +- %-10.3g %s%s", p.name.c_str(), p.value, p.std_error, p.unit.c_str(), p.determined ? "" : "  (not determined)");
  }
  for (const auto& a : d.accepted) {
    line("accepted %s: %s", std::string(effect_name(a.effect)).c_str(), a.trial.verdict.c_str());
    line("  signature: %s", a.trial.signature.summary.c_str());
    for (const auto& p : a.parameters) line("  %-20s %12.5g +- %-10.3g %s", p.name.c_str(), p.value, p.std_error, p.unit.c_str());
  }
  for (const auto& r : d.rejected) line("rejected %s: %s", std::string(effect_name(r.effect)).c_str(), r.reason.c_str());
  auto err = [&](const char* label, const ModelErrors& e) {
    line("%s fit RMS %.4g (NRMSE %.4f, max %.4g, relative %.2f %%), held-out RMS %.4g (NRMSE %.4f, max %.4g, relative %.2f %%)", label,
         e.fit.rms, e.fit.nrmse, e.fit.max_abs, 100 * e.fit.relative, e.heldout.rms, e.heldout.nrmse, e.heldout.max_abs,
         100 * e.heldout.relative);
  };
  err("before:", d.before);
  err("after: ", d.after);
  line("final model (LuGre%s):", d.accepted.empty() ? ", no effect accepted" : " with the accepted effects");
  for (const auto& p : d.final_fit.estimates) {
    line("  %-20s %12.5g +- %-10.3g %s%s%s", p.name.c_str(), p.value, p.std_error, p.unit.c_str(), p.fixed ? "  (held)" : "",
         p.determined || p.fixed ? "" : "  (not determined)");
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
