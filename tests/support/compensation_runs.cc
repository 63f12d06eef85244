#include "tests/support/compensation_runs.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "daemon/controller.h"
#include "daemon/protocol_validator.h"
#include "daemon/run_documents.h"
#include "hal/backend_factory.h"
#include "hal/sim_transducer.h"
#include "proto/run_files.h"
#include "proto/text_format_file.h"
#include "scorecard/experiments.h"
#include "sim/instrument_params.h"

namespace tribo::testing {

v1::Protocol shipped_protocol(const std::string& name) {
  v1::Protocol protocol;
  if (auto error = wire::load_text_proto_file(std::string(TRIBO_SOURCE_DIR) + "/config/protocols/" + name, protocol)) {
    throw std::runtime_error(*error);
  }
  return protocol;
}

v1::Protocol with_friction_model(v1::Protocol protocol, const std::string& report_json, const std::string& report_file) {
  if (report_json.empty()) return protocol;
  v1::FrictionCompensation& c = *protocol.mutable_friction_compensation();
  c.set_report_file(report_file);
  c.set_report_json(report_json);
  return protocol;
}

InProcessRun run_in_process(const v1::DaemonConfig& config, const v1::Protocol& protocol, std::uint64_t seed) {
  const daemon::ProtocolCheck check = daemon::validate_protocol(protocol, config);
  if (!check.ok()) throw std::runtime_error(check.errors.front().field + ": " + check.errors.front().message);
  auto transducer = hal::make_transducer(config, seed);
  if (!transducer) throw std::runtime_error("no backend for this config");
  transducer->begin_session(seed);
  const auto* sim = dynamic_cast<const hal::SimTransducer*>(transducer.get());
  daemon::SpscQueue<Sample> queue(1 << 16);
  daemon::RunControl control;
  daemon::RunTelemetry telemetry;
  daemon::RunLoopConfig loop_config = daemon::run_loop_config_from(config);
  loop_config.time_stages_every = 0;
  daemon::RunLoop loop(*transducer, check.load_function, loop_config, queue, control, telemetry);
  InProcessRun run;
  const v1::PidGains gains[4] = {config.controller().lateral_displacement(), config.controller().lateral_force(),
                                 config.controller().normal_force(), config.controller().normal_displacement()};
  run.start = daemon::make_run_start(protocol, config, check.load_function, gains, seed, "in-process", {});
  run.loop_period_s = transducer->period_s();
  run.samples.reserve(check.load_function.expected_samples() + 1024);
  Sample sample;
  while (loop.tick()) {
    while (queue.try_pop(sample)) run.samples.push_back(sample);
    if (sim) {
      run.true_position_m.push_back(sim->instrument().truth().lateral.position_m);
      run.compensation_n.push_back(loop.controller().last_compensation_n());
      run.true_friction_n.push_back(sim->instrument().truth().friction_n);
      run.true_tilt_n.push_back(sim->instrument().truth().tip_force_n);
      run.drive_n.push_back(loop.controller().last_drive().lateral_force_n);
    }
  }
  while (queue.try_pop(sample)) run.samples.push_back(sample);
  run.outcome = loop.outcome();
  if (run.outcome.end == daemon::RunEnd::kTripped) run.end_reason = daemon::trip_description(run.outcome.trip);
  return run;
}

InProcessRun recorded_run(const std::string& run_dir) {
  std::string error;
  const auto recorded = wire::read_run_directory(run_dir, error);
  if (!recorded) throw std::runtime_error(run_dir + ": " + error);
  return recorded_run(recorded->metadata.start(), recorded->samples, recorded->metadata.stop());
}

InProcessRun recorded_run(const v1::RunStart& start, const v1::SampleBlock& samples, const v1::RunStop& stop) {
  InProcessRun run;
  run.start = start;
  run.loop_period_s = 1.0 / run.start.loop_rate_hz();
  const int n = sample_count(samples);
  run.samples.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) run.samples.push_back(sample_at(samples, i));
  run.outcome.end = stop.exit_status() == v1::FAULT ? daemon::RunEnd::kTripped
                    : stop.exit_status() == v1::ABORT ? daemon::RunEnd::kAborted
                                                       : daemon::RunEnd::kCompleted;
  run.end_reason = stop.reason();
  return run;
}

std::vector<double> record_velocity(const std::vector<Sample>& s, std::size_t first, std::size_t end,
                                    std::size_t half_width) {
  std::vector<double> v(end - first, 0.0);
  for (std::size_t i = first; i < end; ++i) {
    const std::size_t lo = i >= first + half_width ? i - half_width : first;
    const std::size_t hi = std::min(end - 1, i + half_width);
    double st = 0, sx = 0;
    for (std::size_t j = lo; j <= hi; ++j) {
      st += s[j].time_s;
      sx += s[j].lateral_position_m;
    }
    const double n = static_cast<double>(hi - lo + 1), tm = st / n, xm = sx / n;
    double stt = 0, stx = 0;
    for (std::size_t j = lo; j <= hi; ++j) {
      stt += (s[j].time_s - tm) * (s[j].time_s - tm);
      stx += (s[j].time_s - tm) * (s[j].lateral_position_m - xm);
    }
    v[i - first] = stt > 0 ? stx / stt : 0.0;
  }
  return v;
}

namespace {

struct Span {
  std::size_t first = 0, end = 0;  // sample indices [first, end)
};

Span span_of(const InProcessRun& run, std::uint32_t segment) {
  Span sp;
  const auto& s = run.samples;
  while (sp.first < s.size() && s[sp.first].segment_index < segment) ++sp.first;
  sp.end = sp.first;
  while (sp.end < s.size() && s[sp.end].segment_index == segment) ++sp.end;
  return sp;
}

double segment_start_s(const InProcessRun& run, std::uint32_t segment) {
  return run.start.segments(static_cast<int>(segment)).start_s();
}

}  // namespace

std::vector<std::uint32_t> segments_named(const InProcessRun& run, const std::string& prefix) {
  std::vector<std::uint32_t> out;
  for (int i = 0; i < run.start.segments_size(); ++i) {
    if (run.start.segments(i).name().rfind(prefix, 0) == 0) out.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

BreakawayFigures breakaway_figures(const InProcessRun& run, std::uint32_t segment) {
  BreakawayFigures f;
  const Span sp = span_of(run, segment);
  if (sp.end - sp.first < 3) return f;
  const auto& s = run.samples;
  const double dt = s[sp.first + 1].time_s - s[sp.first].time_s;
  const double duration = run.start.segments(static_cast<int>(segment)).duration_s();
  f.commanded_m_per_s = std::fabs(s[sp.end - 1].lateral_setpoint_m - s[sp.first].lateral_setpoint_m) /
                        (duration - dt);
  const double sign = s[sp.end - 1].lateral_setpoint_m >= s[sp.first].lateral_setpoint_m ? 1.0 : -1.0;
  // 10 ms: a centred window of 0.005 s each side.
  const auto half = static_cast<std::size_t>(std::max(1L, std::lround(0.005 / dt)));
  const std::vector<double> v = record_velocity(s, sp.first, sp.end, half);
  double peak = 0;
  f.time_to_speed_s = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < v.size(); ++k) {
    f.peak_lateral_force_n = std::max(f.peak_lateral_force_n, std::fabs(s[sp.first + k].lateral_force_n));
    // Only the full centred windows: at the segment's first and last
    // samples the window fits 6 of 11 samples, and its slope's noise is
    // 2.5 times the full window's (0.76 against 0.30 µm/s sd).
    if (k < half || k + half >= v.size()) continue;
    peak = std::max(peak, sign * v[k]);
    if (std::isnan(f.time_to_speed_s) && sign * v[k] >= f.commanded_m_per_s) {
      f.time_to_speed_s = s[sp.first + k].time_s - segment_start_s(run, segment);
    }
  }
  f.overshoot = peak / f.commanded_m_per_s;
  // 20 ms means, as the summary's stiction peak.
  const auto per_20ms = static_cast<std::size_t>(std::max(1L, std::lround(0.02 / dt)));
  for (std::size_t k = sp.first; k + per_20ms <= sp.end; ++k) {
    double sum = 0;
    for (std::size_t j = k; j < k + per_20ms; ++j) sum += sign * s[j].lateral_force_n;
    f.stiction_peak_n = std::max(f.stiction_peak_n, sum / static_cast<double>(per_20ms));
  }
  f.true_overshoot = std::numeric_limits<double>::quiet_NaN();
  f.true_stiction_peak_n = std::numeric_limits<double>::quiet_NaN();
  if (!run.true_position_m.empty()) {
    const std::size_t per_ms = static_cast<std::size_t>(std::lround(1e-3 / run.loop_period_s));
    const auto t0 = static_cast<std::size_t>(std::llround(segment_start_s(run, segment) / run.loop_period_s));
    const auto t1 = std::min(run.true_position_m.size(),
                             t0 + static_cast<std::size_t>(std::llround(duration / run.loop_period_s)));
    double true_peak = 0;
    for (std::size_t k = t0 + per_ms; k < t1; ++k) {
      true_peak = std::max(true_peak, sign * (run.true_position_m[k] - run.true_position_m[k - per_ms]) /
                                          (static_cast<double>(per_ms) * run.loop_period_s));
    }
    f.true_overshoot = true_peak / f.commanded_m_per_s;
    const auto per_20ms_ticks = static_cast<std::size_t>(std::lround(0.02 / run.loop_period_s));
    double sum = 0, best = 0;
    for (std::size_t k = t0; k < t1; ++k) {
      sum += sign * run.true_friction_n[k] - run.true_tilt_n[k];
      if (k >= t0 + per_20ms_ticks) sum -= sign * run.true_friction_n[k - per_20ms_ticks] - run.true_tilt_n[k - per_20ms_ticks];
      if (k + 1 >= t0 + per_20ms_ticks) best = std::max(best, sum / static_cast<double>(per_20ms_ticks));
    }
    f.true_stiction_peak_n = best;
  }
  return f;
}

TrackingFigures tracking_figures(const InProcessRun& run, const std::string& name) {
  TrackingFigures f;
  double steady_ss = 0, lag_sum = 0, reversal_ss = 0;
  std::size_t steady_n = 0, reversal_n = 0, strokes = 0;
  bool first = true;
  for (std::uint32_t segment : segments_named(run, name)) {
    const Span sp = span_of(run, segment);
    const std::size_t n = sp.end - sp.first;
    const double t0 = segment_start_s(run, segment);
    double stroke_sum = 0;
    std::size_t stroke_n = 0;
    for (std::size_t k = sp.first; k < sp.end; ++k) {
      const Sample& x = run.samples[k];
      const double e = x.lateral_setpoint_m - x.lateral_position_m;
      if (k >= sp.first + n * 6 / 10) {
        steady_ss += e * e;
        stroke_sum += e;
        ++stroke_n;
      }
      if (!first && x.time_s - t0 < 0.5) {
        reversal_ss += e * e;
        ++reversal_n;
        f.reversal_max_m = std::max(f.reversal_max_m, std::fabs(e));
      }
    }
    if (stroke_n > 0) {
      lag_sum += std::fabs(stroke_sum / static_cast<double>(stroke_n));
      steady_n += stroke_n;
      ++strokes;
    }
    first = false;
  }
  if (steady_n > 0) {
    f.steady_rms_m = std::sqrt(steady_ss / static_cast<double>(steady_n));
    f.steady_mean_abs_m = lag_sum / static_cast<double>(strokes);
  }
  if (reversal_n > 0) f.reversal_rms_m = std::sqrt(reversal_ss / static_cast<double>(reversal_n));
  return f;
}

RunExtremes run_extremes(const InProcessRun& run) {
  RunExtremes x;
  for (const Sample& s : run.samples) x.max_abs_lateral_force_n = std::max(x.max_abs_lateral_force_n, std::fabs(s.lateral_force_n));
  for (double c : run.compensation_n) x.max_abs_compensation_n = std::max(x.max_abs_compensation_n, std::fabs(c));
  x.tripped = run.outcome.end == daemon::RunEnd::kTripped;
  if (x.tripped) x.trip = run.end_reason;
  return x;
}

double stick_slip_ratio(const v1::DaemonConfig& config, const daemon::IdentifiedFriction* model, double loop_rate_hz,
                        double velocity, std::uint64_t seed) {
  const v1::DaemonConfig c = scorecard::stick_slip_config(config, loop_rate_hz);
  hal::SimTransducer transducer(sim::instrument_params_from_config(c.sim()), seed, loop_rate_hz, false);
  daemon::Controller controller(daemon::controller_params_from_config(c));
  const double dt = transducer.period_s();
  const auto step = [&](double normal_n, double lateral_m, double rate) {
    daemon::TickSetpoints s;
    s.normal = normal_n;
    s.lateral = lateral_m;
    s.lateral_rate = rate;
    s.friction_model = model;
    hal::SensorFrame frame;
    transducer.read(frame);
    transducer.write(controller.step(s, frame).drive);
    transducer.wait_next_tick();
  };
  // As the scorecard: approach 0 -> 2 µm in 0.3 s, load 1 mN at 1.5 s over
  // 0.5 s, rest until 4 s, then scratch 20 s.
  constexpr double kStartM = 2e-6, kLoadN = 1e-3, kScratchS = 20.0;
  for (long k = 0; k < std::lround(4.0 / dt); ++k) {
    const double t = static_cast<double>(k) * dt;
    step(std::clamp((t - 1.5) / 0.5, 0.0, 1.0) * kLoadN, kStartM * std::min(1.0, t / 0.3),
         t < 0.3 ? kStartM / 0.3 : 0.0);
  }
  const long ticks = std::lround(kScratchS / dt);
  std::vector<double> x;
  for (long k = 0; k < ticks; ++k) {
    step(kLoadN, kStartM + velocity * static_cast<double>(k + 1) * dt, velocity);
    x.push_back(transducer.instrument().truth().lateral.position_m);
  }
  return scorecard::stick_slip_advance_ratio(x, velocity, dt);
}

std::string scaled_report(const std::string& report_json, double level_factor, double stiffness_factor) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(report_json);
  for (auto& p : j.at("final_model").at("parameters")) {
    const std::string name = p.at("name").get<std::string>();
    double factor = 1;
    if (name == "mu_c" || name == "mu_s" || name == "Fc" || name == "Fs" || name == "Fv" || name == "dwell_dFs") {
      factor = level_factor;
    }
    if (name == "sigma0") factor = stiffness_factor;
    p["value"] = p.at("value").get<double>() * factor;
  }
  return j.dump(1);
}

}  // namespace tribo::testing
