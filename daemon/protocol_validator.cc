#include "daemon/protocol_validator.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace tribo::daemon {

namespace {

constexpr double kUm = 1e-6;  // µm and µN to SI
constexpr double kUn = 1e-6;
constexpr double kMaxSegments = 100000;
constexpr double kWarnVelocityUmPerS = 0.2;  // §4.4.1: reliable friction data from 0.2 µm/s

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

class Checker {
 public:
  Checker(const v1::InstrumentLimits& limits, const v1::ControllerConfig& controller)
      : limits_(limits), controller_(controller) {}

  ProtocolCheck run(const v1::Protocol& protocol);

 private:
  void error(std::string field, std::string message) {
    result_.errors.push_back({std::move(field), std::move(message)});
  }
  void check_segment(const v1::Segment& seg, int i);
  double resolve_begin(bool has_begin, double begin, double previous_end, const std::string& field,
                       const char* unit);

  const v1::InstrumentLimits& limits_;
  const v1::ControllerConfig& controller_;
  ProtocolCheck result_;
  std::vector<SegmentPlan> plans_;
  double previous_normal_un_ = 0;  // the instrument starts unloaded at the neutral point
  double previous_lateral_um_ = 0;
  std::uint64_t next_tick_ = 0;
  double protocol_rate_hz_ = 0;
};

double Checker::resolve_begin(bool has_begin, double begin, double previous_end,
                              const std::string& field, const char* unit) {
  if (!has_begin) return previous_end;
  if (std::fabs(begin - previous_end) > 1e-9 * std::max(1.0, std::fabs(previous_end))) {
    error(field, field + " = " + fmt(begin) + " " + unit +
                     " is discontinuous: the previous segment ends at " + fmt(previous_end) + " " +
                     unit + " (omit begin to continue from it)");
  }
  return begin;
}

void Checker::check_segment(const v1::Segment& seg, int i) {
  const std::string at = "segments[" + std::to_string(i) + "]";
  const std::string label = at + (seg.name().empty() ? "" : " \"" + seg.name() + "\"");
  const double loop_hz = controller_.loop_rate_hz();

  // Duration and its tick count.
  const double duration = seg.duration_s();
  const double max_duration = limits_.max_segment_duration_s();
  if (!(duration > 0) || !(duration <= max_duration)) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) + " s must be in (0, " +
                                  fmt(max_duration) + "] s");
    return;
  }
  const double exact_ticks = duration * loop_hz;
  const auto ticks = static_cast<std::uint64_t>(std::llround(exact_ticks));
  if (ticks == 0) {  // found by the protocol_validator fuzz target: 1e-183 s passed as 0 whole periods
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is shorter than one loop period (1/" + fmt(loop_hz) + " s)");
    return;
  }
  if (std::fabs(exact_ticks - static_cast<double>(ticks)) > 1e-6 * std::max(1.0, exact_ticks)) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is not a whole number of loop periods (1/" + fmt(loop_hz) +
                                  " s)");
    return;
  }

  // Acquisition rate.
  double rate = seg.acquisition_rate_hz() > 0 ? seg.acquisition_rate_hz() : protocol_rate_hz_;
  const std::string rate_field =
      seg.acquisition_rate_hz() > 0 ? at + ".acquisition_rate_hz" : "acquisition_rate_hz";
  const double ratio = loop_hz / rate;
  const auto ticks_per_sample = static_cast<std::uint64_t>(std::llround(ratio));
  if (!(rate > 0) || !(rate <= loop_hz) || std::fabs(ratio - static_cast<double>(ticks_per_sample)) > 1e-9 * ratio) {
    error(rate_field, label + ": acquisition rate " + fmt(rate) +
                          " Hz must divide the loop rate " + fmt(loop_hz) + " Hz");
    return;
  }
  if (ticks % ticks_per_sample != 0) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is not a whole number of sample periods (1/" + fmt(rate) +
                                  " s)");
    return;
  }

  // Control modes supported by this controller.
  const auto& normal = seg.normal();
  const auto& lateral = seg.lateral();
  if (normal.mode() != v1::NORMAL_MODE_UNSPECIFIED && normal.mode() != v1::NORMAL_OPEN_LOOP_FORCE) {
    error(at + ".normal.mode", label + ": normal.mode " + v1::NormalMode_Name(normal.mode()) +
                                   " is not supported by this controller (NORMAL_OPEN_LOOP_FORCE is)");
  }
  if (lateral.mode() != v1::LATERAL_MODE_UNSPECIFIED && lateral.mode() != v1::LATERAL_DISPLACEMENT) {
    error(at + ".lateral.mode", label + ": lateral.mode " + v1::LateralMode_Name(lateral.mode()) +
                                    " is not supported by this controller (LATERAL_DISPLACEMENT is)");
  }

  // Setpoints, continuity and limits.
  const double n0 = resolve_begin(normal.has_begin_un(), normal.begin_un(), previous_normal_un_,
                                  at + ".normal.begin_uN", "µN");
  const double n1 = normal.end_un();
  const double x0 = resolve_begin(lateral.has_begin_um(), lateral.begin_um(), previous_lateral_um_,
                                  at + ".lateral.begin_um", "µm");
  const double x1 = lateral.end_um();
  const double max_n_un = limits_.max_normal_force_n() / kUn;
  const double max_x_um = limits_.max_lateral_travel_m() / kUm;
  for (auto [value, field] : {std::pair{n0, ".normal.begin_uN"}, std::pair{n1, ".normal.end_uN"}}) {
    if (!(value >= 0) || !(value <= max_n_un)) {
      error(at + field, label + ": " + std::string(field + 1) + " = " + fmt(value) +
                            " µN is outside the normal force range [0, " + fmt(max_n_un) + "] µN");
    }
  }
  for (auto [value, field] : {std::pair{x0, ".lateral.begin_um"}, std::pair{x1, ".lateral.end_um"}}) {
    if (!(std::fabs(value) <= max_x_um)) {
      error(at + field, label + ": " + std::string(field + 1) + " = " + fmt(value) +
                            " µm is outside the lateral travel [-" + fmt(max_x_um) + ", " +
                            fmt(max_x_um) + "] µm");
    }
  }

  // Velocity.
  const double velocity_um_s = std::fabs(x1 - x0) / duration;
  const double max_v = limits_.max_velocity_m_per_s() / kUm;
  const double min_v = limits_.min_velocity_m_per_s() / kUm;
  const bool loaded = std::max(n0, n1) > 0;
  if (velocity_um_s > max_v) {
    error(at + ".lateral.end_um", label + ": lateral velocity " + fmt(velocity_um_s) +
                                      " µm/s exceeds the maximum " + fmt(max_v) + " µm/s");
  } else if (loaded && velocity_um_s > 0 && velocity_um_s < min_v) {
    error(at + ".lateral.end_um", label + ": loaded lateral velocity " + fmt(velocity_um_s) +
                                      " µm/s is below the minimum " + fmt(min_v) + " µm/s");
  } else if (loaded && velocity_um_s > 0 && velocity_um_s < kWarnVelocityUmPerS) {
    result_.warnings.push_back(label + ": loaded lateral velocity " + fmt(velocity_um_s) +
                               " µm/s is below 0.2 µm/s, where friction data are unreliable");
  }

  // The breakpoint at x = 0: loaded motion must stay on one side (§3.2.5).
  if (loaded && std::min(x0, x1) <= 0 && std::max(x0, x1) >= 0) {
    error(at + ".lateral", label + ": loaded lateral path from " + fmt(x0) + " µm to " + fmt(x1) +
                               " µm touches or crosses the breakpoint at 0 µm; keep loaded "
                               "segments on one side of it");
  }

  plans_.push_back(SegmentPlan{seg.name(), next_tick_, ticks, n0 * kUn, n1 * kUn, x0 * kUm,
                               x1 * kUm, static_cast<std::uint32_t>(ticks_per_sample)});
  next_tick_ += ticks;
  result_.duration_s += duration;
  previous_normal_un_ = n1;
  previous_lateral_um_ = x1;
}

ProtocolCheck Checker::run(const v1::Protocol& protocol) {
  protocol_rate_hz_ = protocol.acquisition_rate_hz() > 0 ? protocol.acquisition_rate_hz()
                                                         : controller_.default_acquisition_rate_hz();
  if (protocol.segments_size() == 0) {
    error("segments", "the protocol has no segments");
  } else if (protocol.segments_size() > kMaxSegments) {
    error("segments", "the protocol has " + std::to_string(protocol.segments_size()) +
                          " segments; at most " + fmt(kMaxSegments) + " are allowed");
  }
  if (!result_.errors.empty()) return std::move(result_);
  for (int i = 0; i < protocol.segments_size(); ++i) check_segment(protocol.segments(i), i);
  if (result_.duration_s > limits_.max_protocol_duration_s()) {
    error("segments", "total duration " + fmt(result_.duration_s) + " s exceeds the maximum " +
                          fmt(limits_.max_protocol_duration_s()) + " s");
  }
  if (result_.errors.empty()) {
    result_.load_function = LoadFunction(std::move(plans_), controller_.loop_rate_hz());
  }
  return std::move(result_);
}

}  // namespace

ProtocolCheck validate_protocol(const v1::Protocol& protocol, const v1::InstrumentLimits& limits,
                                const v1::ControllerConfig& controller) {
  return Checker(limits, controller).run(protocol);
}

}  // namespace tribo::daemon
