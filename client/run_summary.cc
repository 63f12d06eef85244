#include "client/run_summary.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include <google/protobuf/util/json_util.h>

#include "analysis/metrics/run_metrics.h"
#include "analysis/metrics/segment_spans.h"
#include "analysis/metrics/scratch_metrics.h"
#include "analysis/metrics/tip_tilt.h"
#include "client/segment_reader.h"
#include "proto/sample_record.h"

namespace tribo::client {

namespace {

constexpr double kMicro = 1e6;  // SI to µm, µN

// The segment as text shows it: counted from 1 of the total, as the live
// progress line does (JSON's `segment` and samples.csv's segment_index count
// from 0).
std::string segment_label(std::uint32_t segment, std::uint32_t total, const std::string& name) {
  return total > 0 ? fmt::format("segment {}/{} \"{}\"", segment + 1, total, name)
                   : fmt::format("segment {} \"{}\"", segment + 1, name);
}

std::string segment_name(const RunDocuments& run, std::uint32_t segment) {
  // segment_index counts the unrolled segments (RunStart.segments: repeat
  // blocks expanded); older daemons sent only the protocol.
  const auto& unrolled = run.start.segments();
  const auto& segments = run.start.protocol().segments();
  const int i = static_cast<int>(segment);
  if (!unrolled.empty()) return i < unrolled.size() ? unrolled[i].name() : "";
  return i < segments.size() ? segments[i].name() : "";
}

v1::RunSummary summary_header(const RunDocuments& run, std::uint64_t sample_count) {
  v1::RunSummary s;
  s.set_run_id(run.start.run_id());
  s.set_protocol(run.start.protocol().name());
  s.set_exit_status(v1::ExitStatus_Name(run.stop.exit_status()));
  s.set_reason(run.stop.reason());
  s.set_sample_count(static_cast<std::uint32_t>(sample_count));
  s.set_duration_s(static_cast<double>(run.stop.cycle_count()) / run.start.loop_rate_hz());
  s.set_seed(run.start.seed());
  s.set_segment_count(static_cast<std::uint32_t>(
      run.start.segments_size() > 0 ? run.start.segments_size() : run.descriptor.segment_names_size()));
  for (const auto& use : run.start.friction_models()) {
    v1::CompensationSummary* c = s.add_friction_compensation();
    c->set_report_file(use.report_file());
    c->set_report_sha256(use.report_sha256());
    c->set_contact(use.contact());
    c->set_segments(static_cast<std::uint32_t>(use.segments_size()));
  }
  return s;
}

// The tilt the summary corrects with: the passes' offset where the run slid
// both ways; a hold's estimate alone is not checked, and on a contact that
// holds a force at rest it reads less than the tilt, so it is reported but
// not used (analysis/metrics/tip_tilt.h).
std::optional<double> set_tilt(v1::RunSummary& s, const std::optional<analysis::TipTiltEstimate>& hold,
                               const std::optional<analysis::PassesTiltEstimate>& passes) {
  if (hold) {
    s.set_tilt_tan(hold->tan_tilt);
    s.set_tilt_segment(hold->first_segment);
  }
  if (!passes) return std::nullopt;
  s.set_tilt_passes_tan(passes->tan_tilt);
  s.set_tilt_passes_used(passes->forward_passes + passes->backward_passes);
  s.set_tilt_source("passes");
  s.set_tilt_correction_tan(passes->tan_tilt);
  if (hold) s.set_tilt_hold_agrees(analysis::hold_tilt_agrees(hold->tan_tilt, passes->tan_tilt));
  return passes->tan_tilt;
}

void add_scratch(v1::RunSummary& s, const RunDocuments& run, const analysis::SlidingSegmentMetrics& m,
                 const analysis::SlidingCheck& check, std::optional<double> tan_tilt, std::uint32_t stride) {
  v1::SlidingSummary* out = s.add_scratches();
  out->set_segment(m.segment);
  out->set_segment_name(segment_name(run, m.segment));
  out->set_measured_velocity_um_s(check.measured_velocity_m_per_s * kMicro);
  out->set_commanded_travel_um(check.commanded_travel_m * kMicro);
  out->set_measured_travel_um(check.measured_travel_m * kMicro);
  out->set_steady_state(check.steady);
  out->set_not_steady_reason(check.why_not);
  out->set_stiction_peak_found(check.stiction_peak_found);
  out->set_velocity_um_s(m.velocity_m_per_s * kMicro);
  out->set_normal_force_un(m.normal_force_n * kMicro);
  out->set_mean_friction_un(m.mean_friction_n * kMicro);
  out->set_friction_sd_un(m.friction_sd_n * kMicro);
  out->set_mu(m.mu);
  out->set_stiction_peak_un(m.stiction_peak_n * kMicro);
  out->set_stiction_time_s(m.stiction_time_s);
  out->set_steady_lag_um(m.steady_lag_m * kMicro);
  out->set_steady_window_begin_s(m.steady_begin_s);
  out->set_steady_window_end_s(m.end_s);
  out->set_steady_samples(static_cast<std::uint32_t>(m.steady_samples));
  if (tan_tilt) {
    const double corrected_n =
        analysis::tilt_corrected_friction_n(m.mean_friction_n, m.velocity_m_per_s, m.normal_force_n, *tan_tilt);
    out->set_mean_friction_tilt_corrected_un(corrected_n * kMicro);
    out->set_mu_tilt_corrected(m.normal_force_n > 0 ? corrected_n / m.normal_force_n : 0.0);
  }
  if (stride > 1) out->set_sample_stride(stride);
}

v1::OscillationSummary oscillation_summary(const RunDocuments& run, const analysis::OscillationMetrics& o,
                                           std::uint32_t stride) {
  v1::OscillationSummary out;
  out.set_segment(o.segment);
  out.set_segment_name(segment_name(run, o.segment));
  out.set_frequency_hz(o.frequency_hz);
  out.set_cycles(o.cycles);
  out.set_samples(static_cast<std::uint32_t>(o.samples));
  out.set_normal_force_un(o.normal_force_n * kMicro);
  out.set_setpoint_amplitude_um(o.setpoint_amplitude_m * kMicro);
  out.set_position_amplitude_um(o.position_amplitude_m * kMicro);
  out.set_position_phase_deg(o.position_phase_deg);
  out.set_force_amplitude_un(o.force_amplitude_n * kMicro);
  out.set_force_phase_deg(o.force_phase_deg);
  out.set_begin_s(o.begin_s);
  out.set_end_s(o.end_s);
  if (stride > 1) out.set_sample_stride(stride);
  return out;
}

std::string thinned_note(std::uint32_t stride) {
  return fmt::format("    (from every {}th sample: the segment has more than the {} samples the summary holds)\n",
                     stride, kSegmentCapSamples);
}

std::string degrees(double tan_tilt) { return fmt::format("{:.3f}°", std::atan(tan_tilt) * 180 / M_PI); }

// Which tilt the friction is corrected with, and what the hold read.
std::string tilt_text(const v1::RunSummary& s) {
  const std::string hold_at = fmt::format("segment {}/{}", s.tilt_segment() + 1, s.segment_count());
  if (s.tilt_source() == "passes") {
    std::string text = fmt::format(
        "  tip tilt   tan(theta) = {:.5f} ({}) from the passes both ways (half the difference\n"
        "             of their mu, {} passes); friction corrected with it\n",
        s.tilt_passes_tan(), degrees(s.tilt_passes_tan()), s.tilt_passes_used());
    if (s.has_tilt_tan()) {
      text += fmt::format("             the loaded hold in {} read {:.5f}: {}\n", hold_at, s.tilt_tan(),
                          s.tilt_hold_agrees() ? "agrees"
                                               : "disagrees, not used (the contact held part of the tilt's push)");
    }
    return text;
  }
  if (s.has_tilt_tan()) {
    return fmt::format(
        "  tip tilt   tan(theta) = {:.5f} ({}) read at rest under load in {};\n"
        "             not used: no passes both ways to check it (a contact that holds a force at\n"
        "             rest reads less than the tilt); friction not tilt-corrected\n",
        s.tilt_tan(), degrees(s.tilt_tan()), hold_at);
  }
  return "  tip tilt   not measured: no loaded hold before sliding and no passes both ways;\n"
         "             friction not tilt-corrected\n";
}

}  // namespace

v1::RunSummary summarize_run(const RunResult& run) {
  RunSummarizer summarizer(run);
  summarizer.add_segment(run.samples);
  return summarizer.finish(static_cast<std::uint64_t>(sample_count(run.samples)));
}

// The same analysis, a segment at a time: every analysis function called
// here works span by span, so a segment's samples alone give the values the
// whole run gives. Only the tilt correction needs the whole run's estimate:
// the scratches wait for it.
RunSummarizer::RunSummarizer(const RunDocuments& run) : run_(run) {}

void RunSummarizer::add_segment(const v1::SampleBlock& samples, std::uint32_t stride) {
  for (const auto& span : analysis::segment_spans(samples)) {
    tilt_.add(samples, span.first, span.last);
  }
  for (const auto& m : analysis::sliding_segment_metrics(samples)) {
    if (analysis::is_oscillation_segment(samples, m.segment)) continue;
    scratches_.push_back({m, analysis::check_sliding(samples, m), stride});
  }
  for (const auto& o : analysis::oscillation_metrics(samples)) oscillations_.push_back(oscillation_summary(run_, o, stride));
}

v1::RunSummary RunSummarizer::finish(std::uint64_t sample_count) const {
  v1::RunSummary s = summary_header(run_, sample_count);
  std::vector<analysis::PassFriction> passes;
  for (const auto& c : scratches_) {
    if (!c.check.steady) continue;
    passes.push_back({c.metrics.velocity_m_per_s, c.metrics.normal_force_n, c.metrics.mean_friction_n});
  }
  const std::optional<double> tan_tilt = set_tilt(s, tilt_.estimate(), analysis::estimate_tilt_from_passes(passes));
  for (const auto& c : scratches_) add_scratch(s, run_, c.metrics, c.check, tan_tilt, c.stride);
  for (const auto& o : oscillations_) *s.add_oscillations() = o;
  return s;
}

std::optional<v1::RunSummary> summarize_recording(const RunDocuments& run, const std::filesystem::path& run_dir,
                                                  std::uint64_t cap_samples, std::string& error,
                                                  std::uint64_t* peak_samples_held) {
  RunSummarizer summarizer(run);
  SegmentReadResult read;
  const bool ok = for_each_segment(run_dir, cap_samples, [&](const SegmentSamples& segment) {
    summarizer.add_segment(segment.samples, segment.stride);
  }, read, error);
  if (peak_samples_held) *peak_samples_held = read.peak_samples_held;
  if (!ok) return std::nullopt;
  return summarizer.finish(read.rows);
}

std::string summary_text(const v1::RunSummary& s) {
  std::string text = fmt::format("run {}: {}", s.run_id(), s.exit_status());
  if (!s.reason().empty()) text += " (" + s.reason() + ")";
  text += fmt::format("\n  protocol   {}, {:.3f} s, {} samples, seed {}\n", s.protocol(), s.duration_s(),
                      s.sample_count(), s.seed());
  text += tilt_text(s);
  for (const auto& c : s.friction_compensation()) {
    text += fmt::format("  compensated {}, model {} (SHA-256 {}), {} of {} segments\n", c.contact(), c.report_file(),
                        c.report_sha256().substr(0, 12), c.segments(), s.segment_count());
  }
  if (s.scratches_size() == 0 && s.oscillations_size() == 0) {
    text += "  no loaded sliding segment: no friction to report\n";
  }
  for (const auto& c : s.scratches()) {
    text += fmt::format("  {}: {:+.3f} µm/s commanded at {:.1f} µN normal force\n",
                        segment_label(c.segment(), s.segment_count(), c.segment_name()), c.velocity_um_s(),
                        c.normal_force_un());
    text += fmt::format("    moved          {:+9.3f} µm/s measured, {:.3f} of {:.3f} µm travelled\n",
                        c.measured_velocity_um_s(), c.measured_travel_um(), c.commanded_travel_um());
    text += c.steady_state() ? "    steady state   reached\n"
                             : "    steady state   NOT reached: " + c.not_steady_reason() +
                                   "\n                   (friction and mu below describe a transient)\n";
    text += fmt::format("    mean friction  {:9.2f} µN  (sd {:.2f} µN over {} samples, t = {:.3f}..{:.3f} s)\n",
                        c.mean_friction_un(), c.friction_sd_un(), c.steady_samples(), c.steady_window_begin_s(),
                        c.steady_window_end_s());
    text += fmt::format("    mu = F/N       {:9.4f}\n", c.mu());
    if (c.has_mean_friction_tilt_corrected_un()) {
      text += fmt::format("    friction (tilt-corrected)  {:9.2f} µN, mu {:.4f}\n", c.mean_friction_tilt_corrected_un(),
                          c.mu_tilt_corrected());
    }
    text += c.stiction_peak_found()
                ? fmt::format("    stiction peak  {:9.2f} µN  at {:.3f} s after motion onset\n", c.stiction_peak_un(),
                              c.stiction_time_s())
                : "    stiction peak  none (the friction never rose above its steady mean)\n";
    text += fmt::format("    steady lag     {:9.4f} µm  (commanded minus measured position)\n", c.steady_lag_um());
    if (c.has_sample_stride()) text += thinned_note(c.sample_stride());
  }
  for (const auto& o : s.oscillations()) {
    text += fmt::format("  {}: oscillation {:.3g} Hz x {:.0f} cycles at {:.1f} µN normal force\n",
                        segment_label(o.segment(), s.segment_count(), o.segment_name()), o.frequency_hz(), o.cycles(),
                        o.normal_force_un());
    text += fmt::format("    position       {:9.4f} µm amplitude ({:.4f} µm commanded), phase {:+.1f}° to the setpoint\n",
                        o.position_amplitude_um(), o.setpoint_amplitude_um(), o.position_phase_deg());
    text += fmt::format("    lateral force  {:9.2f} µN amplitude, phase {:+.1f}° to the position\n",
                        o.force_amplitude_un(), o.force_phase_deg());
    if (o.has_sample_stride()) text += thinned_note(o.sample_stride());
  }
  if (!s.saved_to().empty()) text += "  saved to   " + s.saved_to() + "\n";
  return text;
}

std::string summary_json(const v1::RunSummary& summary) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(summary, &json, options);
  return json;
}

}  // namespace tribo::client
