#include "client/run_summary.h"

#include <cmath>
#include <cstdio>

#include <google/protobuf/util/json_util.h>

#include "analysis/run_metrics.h"
#include "analysis/tip_tilt.h"
#include "proto/sample_record.h"

namespace tribo::client {

namespace {

constexpr double kMicro = 1e6;  // SI to µm, µN

std::string format(const char* fmt, auto... args) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, args...);
  return buf;
}

}  // namespace

v1::RunSummary summarize_run(const RunResult& run) {
  v1::RunSummary s;
  s.set_run_id(run.start.run_id());
  s.set_protocol(run.start.protocol().name());
  s.set_exit_status(v1::ExitStatus_Name(run.stop.exit_status()));
  s.set_reason(run.stop.reason());
  s.set_sample_count(static_cast<std::uint32_t>(sample_count(run.samples)));
  s.set_duration_s(static_cast<double>(run.stop.cycle_count()) / run.start.loop_rate_hz());
  s.set_seed(run.start.seed());
  // segment_index counts the unrolled segments (RunStart.segments: repeat
  // blocks expanded); older daemons sent only the protocol.
  const auto& unrolled = run.start.segments();
  const auto& segments = run.start.protocol().segments();
  const auto tilt = analysis::estimate_tip_tilt(run.samples);
  if (tilt) {
    s.set_tilt_tan(tilt->tan_tilt);
    s.set_tilt_segment(tilt->first_segment);
  }
  for (const auto& m : analysis::sliding_segment_metrics(run.samples)) {
    v1::SlidingSummary* out = s.add_scratches();
    out->set_segment(m.segment);
    const int i = static_cast<int>(m.segment);
    if (!unrolled.empty()) {
      if (i < unrolled.size()) out->set_segment_name(unrolled[i].name());
    } else if (i < segments.size()) {
      out->set_segment_name(segments[i].name());
    }
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
    if (tilt) {
      const double corrected_n =
          analysis::tilt_corrected_friction_n(m.mean_friction_n, m.velocity_m_per_s, m.normal_force_n, tilt->tan_tilt);
      out->set_mean_friction_tilt_corrected_un(corrected_n * kMicro);
      out->set_mu_tilt_corrected(m.normal_force_n > 0 ? corrected_n / m.normal_force_n : 0.0);
    }
  }
  return s;
}

std::string summary_text(const v1::RunSummary& s) {
  std::string text = format("run %s: %s", s.run_id().c_str(), s.exit_status().c_str());
  if (!s.reason().empty()) text += " (" + s.reason() + ")";
  text += format("\n  protocol   %s, %.3f s, %llu samples, seed %llu\n", s.protocol().c_str(),
                 s.duration_s(), static_cast<unsigned long long>(s.sample_count()),
                 static_cast<unsigned long long>(s.seed()));
  if (s.has_tilt_tan()) {
    text += format("  tip tilt   tan(theta) = %.5f (%.3f°), measured at rest under load in segment %u\n",
                   s.tilt_tan(), std::atan(s.tilt_tan()) * 180 / M_PI, s.tilt_segment());
  } else {
    text += "  tip tilt   not measured: no loaded hold before sliding; friction not tilt-corrected\n";
  }
  if (s.scratches_size() == 0) text += "  no loaded sliding segment: no friction to report\n";
  for (const auto& c : s.scratches()) {
    text += format("  segment %u \"%s\": %+.3f µm/s at %.1f µN normal force\n", c.segment(),
                   c.segment_name().c_str(), c.velocity_um_s(), c.normal_force_un());
    text += format("    mean friction  %9.2f µN  (sd %.2f µN over %llu samples, t = %.3f..%.3f s)\n",
                   c.mean_friction_un(), c.friction_sd_un(),
                   static_cast<unsigned long long>(c.steady_samples()), c.steady_window_begin_s(),
                   c.steady_window_end_s());
    text += format("    mu = F/N       %9.4f\n", c.mu());
    if (c.has_mean_friction_tilt_corrected_un()) {
      text += format("    friction (tilt-corrected)  %9.2f µN, mu %.4f\n", c.mean_friction_tilt_corrected_un(),
                     c.mu_tilt_corrected());
    }
    text += format("    stiction peak  %9.2f µN  at %.3f s after motion onset\n", c.stiction_peak_un(),
                   c.stiction_time_s());
    text += format("    steady lag     %9.4f µm  (commanded minus measured position)\n",
                   c.steady_lag_um());
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
