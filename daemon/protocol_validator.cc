#include "daemon/protocol_validator.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>
#include <variant>

#include "daemon/electrostatic_drive.h"
#include "daemon/field_bounds.h"
#include "daemon/friction_observer.h"
#include "daemon/safety_supervisor.h"

namespace tribo::daemon {

namespace {

constexpr double kMicro = 1e-6;  // µm and µN to SI
constexpr std::size_t kMaxSegments = 100000;
constexpr std::size_t kMaxErrors = 50;
constexpr double kWarnVelocityUmPerS = 0.2;  // §4.4.1: reliable friction data from 0.2 µm/s
constexpr double kMinTicksPerSineCycle = 20;

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// What the validator knows of a value: it lies in [lo, hi].
struct Range {
  double lo = 0, hi = 0;
  static Range point(double v) { return {v, v}; }
  Range hull(const Range& o) const { return {std::min(lo, o.lo), std::max(hi, o.hi)}; }
  Range shifted(double d) const { return {lo + d, hi + d}; }
  Range widened(double w) const { return {lo - std::fabs(w), hi + std::fabs(w)}; }
  double max_abs() const { return std::max(std::fabs(lo), std::fabs(hi)); }
  double mid() const { return 0.5 * (lo + hi); }
  bool is_point() const { return lo == hi; }
};

// A rate field is unset only at +0: -0, negatives and NaN are set (and wrong).
bool is_set_rate(double hz) { return hz != 0 || std::signbit(hz); }

std::string range_text(const Range& r, const char* unit) {
  if (r.is_point()) return fmt(r.lo) + " " + unit;
  return "[" + fmt(r.lo) + ", " + fmt(r.hi) + "] " + unit;
}

// One axis command in the unit of its mode, whichever axis it belongs to.
struct AxisFields {
  std::string prefix;  // "segments[2].lateral"
  const char* unit = "µm";
  const char* suffix = "um";  // field name suffix of the mode's unit
  std::optional<double> begin, end, delta;
  Shape shape = Shape::kRamp;
  bool has_sine = false;
  double frequency_hz = 0, amplitude = 0;
  std::optional<double> end_amplitude;
  double rate_begin = 0, rate_end = 0;
  std::vector<std::string> wrong_unit;  // fields of the other unit that are set
};

Shape shape_of(v1::Shape s, bool& known) {
  known = true;
  switch (s) {
    case v1::SHAPE_UNSPECIFIED:
    case v1::RAMP: return Shape::kRamp;
    case v1::HOLD: return Shape::kHold;
    case v1::SINE: return Shape::kSine;
    case v1::VELOCITY_PROFILE: return Shape::kVelocityProfile;
    default: known = false; return Shape::kRamp;
  }
}

template <typename Command>
AxisFields axis_fields(const Command& c, const std::string& prefix, bool force_unit) {
  AxisFields f;
  f.prefix = prefix;
  f.unit = force_unit ? "µN" : "µm";
  f.suffix = force_unit ? "uN" : "um";
  const auto opt = [](bool has, double v) { return has ? std::optional<double>(v) : std::nullopt; };
  const auto& s = c.sine();
  const auto& v = c.velocity();
  if (force_unit) {
    f.begin = opt(c.has_begin_un(), c.begin_un());
    f.end = opt(c.has_end_un(), c.end_un());
    f.delta = opt(c.has_delta_un(), c.delta_un());
    f.amplitude = s.amplitude_un();
    f.end_amplitude = opt(s.has_end_amplitude_un(), s.end_amplitude_un());
    f.rate_begin = v.begin_un_per_s();
    f.rate_end = v.end_un_per_s();
    if (c.has_begin_um()) f.wrong_unit.push_back("begin_um");
    if (c.has_end_um()) f.wrong_unit.push_back("end_um");
    if (c.has_delta_um()) f.wrong_unit.push_back("delta_um");
    if (s.amplitude_um() != 0 || s.has_end_amplitude_um()) f.wrong_unit.push_back("sine.amplitude_um");
    if (v.begin_um_per_s() != 0 || v.end_um_per_s() != 0) f.wrong_unit.push_back("velocity.*_um_per_s");
  } else {
    f.begin = opt(c.has_begin_um(), c.begin_um());
    f.end = opt(c.has_end_um(), c.end_um());
    f.delta = opt(c.has_delta_um(), c.delta_um());
    f.amplitude = s.amplitude_um();
    f.end_amplitude = opt(s.has_end_amplitude_um(), s.end_amplitude_um());
    f.rate_begin = v.begin_um_per_s();
    f.rate_end = v.end_um_per_s();
    if (c.has_begin_un()) f.wrong_unit.push_back("begin_uN");
    if (c.has_end_un()) f.wrong_unit.push_back("end_uN");
    if (c.has_delta_un()) f.wrong_unit.push_back("delta_uN");
    if (s.amplitude_un() != 0 || s.has_end_amplitude_un()) f.wrong_unit.push_back("sine.amplitude_uN");
    if (v.begin_un_per_s() != 0 || v.end_un_per_s() != 0) f.wrong_unit.push_back("velocity.*_uN_per_s");
  }
  f.has_sine = c.has_sine();
  f.frequency_hz = s.frequency_hz();
  return f;
}

// An axis path checked and reduced to what the limits need (protocol units).
struct PathSummary {
  AxisPath plan;         // protocol units until converted
  Range begin, end, extent;
  double max_rate = 0;   // unit per second
  double nominal_rate = 0;
  double max_acceleration = 0;
  bool ok = true;
};

// What the validator knows of an axis at a segment boundary.
struct AxisState {
  int mode = 0;  // normalised proto enum value
  Range value;   // in the unit of the mode
};

class Checker {
 public:
  explicit Checker(const v1::DaemonConfig& config);
  ProtocolCheck run(const v1::Protocol& protocol);

 private:
  void error(std::string field, std::string message) {
    if (result_.errors.size() >= kMaxErrors) return;
    ValidationIssue issue{std::move(field), std::move(message), "", ""};
    if (segment_ != nullptr && issue.message.starts_with(segment_->label + ": ")) {
      issue.segment = segment_->subject;
      issue.pass = segment_->pass;
    }
    result_.errors.push_back(std::move(issue));
  }
  void check_segment(const ExpandedSegment& e);
  PathSummary check_path(const AxisFields& f, const std::string& label, bool start_fresh,
                         const Range& measured, const AxisState& previous, double duration_s);
  void check_lateral_pull_in(const std::string& label, const std::string& field,
                             const Range& position_um, const Range& drive_extra_un);
  std::optional<double> lateral_distance_um(const AxisFields& f, const AxisState& previous,
                                            bool start_fresh) const;
  int friction_model(const v1::FrictionCompensation& c, const std::string& field, const std::string& label);
  int segment_friction_model(const v1::Segment& seg, const std::string& at, const std::string& label,
                             bool lateral_force_mode);
  void check_compensation_bound(int model, const std::string& field, const std::string& label,
                                double max_load_un, double max_speed_um_per_s, double elapsed_s);

  const v1::DaemonConfig& config_;
  double loop_hz_;
  ElectrostaticAxis normal_axis_, lateral_axis_;
  ProtocolCheck result_;
  std::vector<SegmentPlan> plans_;
  std::uint64_t next_tick_ = 0;
  double protocol_rate_hz_ = 0;
  std::string protocol_rate_field_ = "acquisition_rate_hz";
  bool first_ = true;
  const ExpandedSegment* segment_ = nullptr;  // the one being checked
  AxisState normal_{v1::NORMAL_OPEN_LOOP_FORCE, Range::point(0)};    // unloaded at rest
  AxisState lateral_{v1::LATERAL_DISPLACEMENT, Range::point(0)};     // at the neutral point
  Range lateral_position_um_ = Range::point(0);
  Range normal_drive_un_ = Range::point(0);
  double max_compensation_n_;                    // supervisor.max_friction_compensation_n, or its default
  std::vector<FrictionReport> friction_models_;  // one per distinct report
  int protocol_friction_model_ = -1;             // the protocol's, -1 none
  std::string protocol_friction_field_ = "friction_compensation";
};

Checker::Checker(const v1::DaemonConfig& config)
    : config_(config),
      loop_hz_(config.controller().loop_rate_hz()),
      normal_axis_(electrostatic_axis_from_config(config.transducer().normal())),
      lateral_axis_(electrostatic_axis_from_config(config.transducer().lateral())),
      max_compensation_n_(supervisor_params_from_config(config).max_friction_compensation_n) {}

std::optional<double> Checker::lateral_distance_um(const AxisFields& f, const AxisState& previous,
                                                   bool start_fresh) const {
  if (f.delta) return *f.delta;
  if (!f.end) return std::nullopt;
  Range begin = f.begin ? Range::point(*f.begin) : start_fresh ? lateral_position_um_ : previous.value;
  if (!begin.is_point()) return std::nullopt;
  return *f.end - begin.lo;
}

// The index of the compensation's model in friction_models_ (a report read
// once however many segments use it), -1 for none or an error.
int Checker::friction_model(const v1::FrictionCompensation& c, const std::string& field, const std::string& label) {
  if (c.off()) {
    if (!c.report_json().empty() || !c.report_file().empty()) {
      error(field + ".off", label + ": friction_compensation.off and a report at once: give one");
    }
    return -1;
  }
  if (c.report_json().empty()) {
    error(field + ".report_json", label + ": friction_compensation has no report" +
                                      (c.report_file().empty() ? std::string()
                                                               : " (report_file " + c.report_file() +
                                                                     " was not read: the client sends its bytes in report_json)"));
    return -1;
  }
  const std::string hash = sha256_hex(c.report_json());
  for (std::size_t i = 0; i < friction_models_.size(); ++i) {
    if (friction_models_[i].sha256 == hash) return static_cast<int>(i);
  }
  auto report = read_friction_report(c.report_json());
  if (auto* why = std::get_if<std::string>(&report)) {
    const std::string name = c.report_file().empty() ? std::string("the friction model report") : c.report_file();
    error(field + ".report_json", label + ": friction compensation: " + name + ": " + *why);
    return -1;
  }
  FrictionReport& r = std::get<FrictionReport>(report);
  r.report_file = c.report_file();
  friction_models_.push_back(std::move(r));
  return static_cast<int>(friction_models_.size() - 1);
}

int Checker::segment_friction_model(const v1::Segment& seg, const std::string& at, const std::string& label,
                                    bool lateral_force_mode) {
  if (!seg.has_friction_compensation()) return lateral_force_mode ? -1 : protocol_friction_model_;
  const std::string field = at + ".friction_compensation";
  if (lateral_force_mode && !seg.friction_compensation().off()) {
    error(field, label + ": friction_compensation applies to LATERAL_DISPLACEMENT segments only");
    return -1;
  }
  return friction_model(seg.friction_compensation(), field, label);
}

// The most the model can ask of the drive along this segment: its friction
// level's bound at the highest load and speed by the segment's end
// (identified_friction_bound), the viscous and bristle-damping terms at the
// highest speed, the tilt's push; beyond the supervisor's limit the run would
// trip, so it is refused here.
void Checker::check_compensation_bound(int model, const std::string& field, const std::string& label,
                                       double max_load_un, double max_speed_um_per_s, double elapsed_s) {
  const FrictionReport& r = friction_models_[static_cast<std::size_t>(model)];
  const IdentifiedFriction& m = r.model;
  const double load_n = max_load_un * kMicro, speed = max_speed_um_per_s * kMicro;
  const double level = identified_friction_bound(m, speed, load_n, elapsed_s);
  const double viscous = std::fabs(m.viscous_n_s_per_m) * (m.direction_asymmetry ? 1 + std::fabs(m.asymmetry_viscous) : 1);
  const double bound = level + (viscous + m.sigma1_n_s_per_m) * speed + std::fabs(m.tilt_tan) * load_n;
  const double limit = max_compensation_n_;
  if (!(bound <= limit)) {
    error(field, label + ": friction compensation (" + (r.report_file.empty() ? r.contact : r.report_file) +
                     ") may reach " + fmt(bound / kMicro) + " µN at " + fmt(max_load_un) + " µN and " +
                     fmt(max_speed_um_per_s) + " µm/s" +
                     (m.rate_state ? " within " + fmt(elapsed_s) + " s of the run's start" : std::string()) +
                     ", beyond supervisor.max_friction_compensation_n = " +
                     fmt(limit / kMicro) + " µN");
  }
}

PathSummary Checker::check_path(const AxisFields& f, const std::string& label, bool start_fresh,
                                const Range& measured, const AxisState& previous,
                                double duration_s) {
  PathSummary s;
  const std::string u = f.unit;
  const auto fail = [&](const std::string& field, const std::string& message) {
    error(f.prefix + "." + field, label + ": " + message);
    s.ok = false;
  };
  for (const std::string& w : f.wrong_unit) {
    fail(w, f.prefix.substr(f.prefix.rfind('.') + 1) + "." + w +
                " is set, but this mode is set in " + u + " (use the _" + f.suffix + " fields)");
  }
  s.plan.shape = f.shape;

  // Begin.
  if (f.begin) {
    s.begin = Range::point(*f.begin);
    s.plan.begin = *f.begin;
    if (!start_fresh) {
      const double tol = 1e-9 * std::max(1.0, previous.value.max_abs());
      if (*f.begin < previous.value.lo - tol || *f.begin > previous.value.hi + tol) {
        fail(std::string("begin_") + f.suffix,
             "begin_" + std::string(f.suffix) + " = " + fmt(*f.begin) + " " + u +
                 " is discontinuous: the previous segment ends at " + range_text(previous.value, f.unit) +
                 " (omit begin to continue from it)");
      }
    }
  } else if (start_fresh) {
    s.begin = measured;
    s.plan.begin_from_measured = true;
  } else {
    s.begin = previous.value;
    s.plan.begin_continues = true;
  }

  // End.
  if (f.end && f.delta) {
    fail(std::string("delta_") + f.suffix, "give end_" + std::string(f.suffix) + " or delta_" +
                                               f.suffix + ", not both");
  }
  switch (f.shape) {
    case Shape::kHold:
      if ((f.end && !(s.begin.is_point() && *f.end == s.begin.lo)) || (f.delta && *f.delta != 0)) {
        fail(std::string(f.end ? "end_" : "delta_") + f.suffix,
             "a HOLD stays at its begin " + range_text(s.begin, f.unit) + "; omit the end");
      }
      s.end = s.begin;
      break;
    case Shape::kVelocityProfile: {
      if (f.end || f.delta) {
        fail(std::string(f.end ? "end_" : "delta_") + f.suffix,
             "a VELOCITY_PROFILE ends where its rates take it; omit the end");
      }
      s.plan.rate_begin = f.rate_begin;
      s.plan.rate_end = f.rate_end;
      const double travel = 0.5 * (f.rate_begin + f.rate_end) * duration_s;
      s.end = s.begin.shifted(travel);
      break;
    }
    case Shape::kRamp:
    case Shape::kSine:
      if (f.delta) {
        s.plan.end_relative = true;
        s.plan.end = *f.delta;
        s.end = s.begin.shifted(*f.delta);
      } else if (f.end) {
        s.plan.end = *f.end;
        s.end = Range::point(*f.end);
      } else {
        s.plan.end_relative = true;  // neither: hold at begin
        s.end = s.begin;
      }
      break;
  }

  // Extent, rates and accelerations.
  s.extent = s.begin.hull(s.end);
  const double ramp_rate_lo = (s.end.lo - s.begin.hi) / duration_s;
  const double ramp_rate_hi = (s.end.hi - s.begin.lo) / duration_s;
  const double exact_ramp = s.plan.end_relative ? (s.end.lo - s.begin.lo) / duration_s
                                                : (s.end.mid() - s.begin.mid()) / duration_s;
  s.nominal_rate = std::fabs(exact_ramp);
  s.max_rate = s.plan.end_relative ? std::fabs(exact_ramp)
                                   : std::max(std::fabs(ramp_rate_lo), std::fabs(ramp_rate_hi));
  if (f.shape == Shape::kSine) {
    if (!(f.frequency_hz > 0) || f.frequency_hz > loop_hz_ / kMinTicksPerSineCycle) {
      fail("sine.frequency_hz", "sine.frequency_hz = " + fmt(f.frequency_hz) + " Hz must be in (0, " +
                                    fmt(loop_hz_ / kMinTicksPerSineCycle) + "] Hz (" +
                                    fmt(kMinTicksPerSineCycle) + " loop ticks per cycle)");
    } else {
      const double cycles = f.frequency_hz * duration_s;
      if (std::fabs(cycles - std::round(cycles)) > 1e-6 * std::max(1.0, cycles)) {
        fail("sine.frequency_hz", "sine.frequency_hz = " + fmt(f.frequency_hz) + " Hz over duration_s = " +
                                      fmt(duration_s) + " s makes " + fmt(cycles) +
                                      " cycles; a SINE segment holds whole cycles (continuity)");
      }
    }
    const double a0 = f.amplitude, a1 = f.end_amplitude.value_or(f.amplitude);
    s.plan.sine_frequency_hz = f.frequency_hz;
    s.plan.sine_amplitude_begin = a0;
    s.plan.sine_amplitude_end = a1;
    const double a_max = std::max(std::fabs(a0), std::fabs(a1));
    const double w = 2 * std::numbers::pi * f.frequency_hz;
    const double growth = std::fabs(a1 - a0) / duration_s;
    s.extent = s.extent.widened(a_max);
    s.max_rate += w * a_max + growth;
    s.max_acceleration = w * w * a_max + 2 * w * growth;
  } else if (f.has_sine && (f.amplitude != 0 || f.frequency_hz != 0)) {
    fail("sine", "sine is set but shape is not SINE");
  }
  if (f.shape == Shape::kVelocityProfile) {
    const double r0 = f.rate_begin, r1 = f.rate_end;
    s.max_rate = std::max(std::fabs(r0), std::fabs(r1));
    s.nominal_rate = s.max_rate;
    s.max_acceleration = std::fabs(r1 - r0) / duration_s;
    if (r0 * r1 < 0) {  // the path turns inside the segment
      const double t = r0 * duration_s / (r0 - r1);
      s.extent = s.extent.hull(s.begin.shifted(r0 * t + (r1 - r0) * t * t / (2 * duration_s)));
    }
  }
  return s;
}

void Checker::check_lateral_pull_in(const std::string& label, const std::string& field,
                                    const Range& position_um, const Range& drive_extra_un) {
  // The worst corner of position and extra drive (friction or force setpoint).
  const double min_ratio = config_.supervisor().min_stiffness_ratio();
  DriveAssessment worst;
  double worst_x_um = 0, worst_force = 0;
  bool first = true;
  for (const double x_um : {position_um.lo, position_um.hi}) {
    for (const double extra_un : {drive_extra_un.lo, drive_extra_un.hi}) {
      const double x = x_um * kMicro;
      const double force = lateral_axis_.spring_n_per_m * x + extra_un * kMicro;
      const DriveAssessment a = assess_drive(lateral_axis_, force, x, 0.0);
      if (first || a.gap_closed || a.stiffness_ratio < worst.stiffness_ratio) {
        worst = a;
        worst_x_um = x_um;
        worst_force = force;
        first = false;
      }
    }
  }
  if (worst.gap_closed || worst.stiffness_ratio < min_ratio) {
    error(field, label + ": pull-in margin: at x = " + fmt(worst_x_um) + " µm the lateral drive of " +
                     fmt(worst_force / kMicro) + " µN leaves k_eff/k = " + fmt(worst.stiffness_ratio) +
                     ", below the minimum " + fmt(min_ratio) + " (needs " + fmt(worst.active_voltage_v) +
                     " V, pull-in at " + fmt(worst.pull_in_voltage_v) + " V)");
  }
}

void Checker::check_segment(const ExpandedSegment& e) {
  const v1::Segment& seg = e.segment;
  const std::string& at = e.path;
  const std::string& label = e.label;
  const auto& lim = config_.limits();

  // Modes.
  int normal_mode = seg.normal().mode() == v1::NORMAL_MODE_UNSPECIFIED ? v1::NORMAL_OPEN_LOOP_FORCE
                                                                       : seg.normal().mode();
  int lateral_mode = seg.lateral().mode() == v1::LATERAL_MODE_UNSPECIFIED ? v1::LATERAL_DISPLACEMENT
                                                                          : seg.lateral().mode();
  if (!v1::NormalMode_IsValid(normal_mode)) {
    error(at + ".normal.mode", label + ": normal.mode " + std::to_string(normal_mode) + " is unknown");
    return;
  }
  if (!v1::LateralMode_IsValid(lateral_mode)) {
    error(at + ".lateral.mode", label + ": lateral.mode " + std::to_string(lateral_mode) + " is unknown");
    return;
  }
  bool known_shape = true;
  const Shape normal_shape = shape_of(seg.normal().shape(), known_shape);
  const Shape lateral_shape = known_shape ? shape_of(seg.lateral().shape(), known_shape) : Shape::kRamp;
  if (!known_shape) {
    error(at, label + ": unknown shape");
    return;
  }
  const bool normal_force_mode = normal_mode != v1::NORMAL_DISPLACEMENT;
  const bool lateral_force_mode = lateral_mode == v1::LATERAL_FORCE;
  const bool normal_fresh = first_ || normal_mode != normal_.mode;
  const bool lateral_fresh = first_ || lateral_mode != lateral_.mode;
  AxisFields nf = axis_fields(seg.normal(), at + ".normal", normal_force_mode);
  nf.shape = normal_shape;
  AxisFields lf = axis_fields(seg.lateral(), at + ".lateral", lateral_force_mode);
  lf.shape = lateral_shape;

  // Acquisition rate: 0 (unset) takes the protocol's; anything else, -0
  // included, must be a rate.
  const bool own_rate = is_set_rate(seg.acquisition_rate_hz());
  const double rate = own_rate ? seg.acquisition_rate_hz() : protocol_rate_hz_;
  const std::string rate_field = own_rate ? at + ".acquisition_rate_hz" : protocol_rate_field_;
  const double ratio = loop_hz_ / rate;
  const auto ticks_per_sample = static_cast<std::uint64_t>(std::llround(ratio));
  if (!(rate > 0) || !(rate <= loop_hz_) ||
      std::fabs(ratio - static_cast<double>(ticks_per_sample)) > 1e-9 * ratio) {
    error(rate_field, label + ": acquisition rate " + fmt(rate) + " Hz must divide the loop rate " +
                          fmt(loop_hz_) + " Hz");
    return;
  }

  // Duration, possibly from the lateral speed.
  double duration = seg.duration_s();
  const double speed = seg.lateral().speed_um_per_s();
  if (speed != 0) {
    const std::string field = at + ".lateral.speed_um_per_s";
    if (lateral_force_mode || lateral_shape != Shape::kRamp) {
      error(field, label + ": lateral.speed_um_per_s needs a RAMP in LATERAL_DISPLACEMENT");
      return;
    }
    if (duration != 0) {
      error(at + ".duration_s", label + ": give duration_s or lateral.speed_um_per_s, not both (duration_s = " +
                                    fmt(duration) + " s)");
      return;
    }
    const auto distance = lateral_distance_um(lf, lateral_, lateral_fresh);
    if (!(speed > 0) || !distance || *distance == 0) {
      error(field, label + ": lateral.speed_um_per_s = " + fmt(speed) +
                       " µm/s needs a positive speed and a known, non-zero distance (delta_um, or "
                       "end_um from a known begin)");
      return;
    }
    const double samples = std::max(1.0, std::round(std::fabs(*distance) / speed * rate));
    duration = samples / rate;
  }
  const double max_duration = lim.max_segment_duration_s();
  if (!(duration > 0) || !(duration <= max_duration)) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) + " s must be in (0, " +
                                  fmt(max_duration) + "] s");
    return;
  }
  const double exact_ticks = duration * loop_hz_;
  const auto ticks = static_cast<std::uint64_t>(std::llround(exact_ticks));
  if (ticks == 0) {  // found by the protocol_validator fuzz target: 1e-183 s passed as 0 whole periods
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is shorter than one loop period (1/" + fmt(loop_hz_) + " s)");
    return;
  }
  if (std::fabs(exact_ticks - static_cast<double>(ticks)) > 1e-6 * std::max(1.0, exact_ticks)) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is not a whole number of loop periods (1/" + fmt(loop_hz_) + " s)");
    return;
  }
  if (ticks % ticks_per_sample != 0) {
    error(at + ".duration_s", label + ": duration_s = " + fmt(duration) +
                                  " s is not a whole number of sample periods (1/" + fmt(rate) + " s)");
    return;
  }
  duration = static_cast<double>(ticks) / loop_hz_;

  // Paths. A fresh begin comes from the measured value, bounded here.
  const double max_n_un = lim.max_normal_force_n() / kMicro;
  const double max_nx_um = lim.max_normal_travel_m() / kMicro;
  const double max_lf_un = lim.max_lateral_force_n() / kMicro;
  const double max_x_um = lim.max_lateral_travel_m() / kMicro;
  Range normal_measured = Range::point(0);  // the run starts unloaded at rest
  if (!first_) {
    switch (normal_mode) {
      case v1::NORMAL_OPEN_LOOP_FORCE: normal_measured = normal_drive_un_; break;
      case v1::NORMAL_CLOSED_LOOP_FORCE:  // the contact carries at most the drive
        normal_measured = normal_.mode == v1::NORMAL_DISPLACEMENT ? Range{0, max_n_un}
                                                                  : Range{0, std::max(0.0, normal_drive_un_.hi)};
        break;
      default: normal_measured = {0, max_nx_um}; break;
    }
  }
  const Range lateral_measured =
      lateral_force_mode ? (first_ ? Range::point(0) : Range{-max_lf_un, max_lf_un}) : lateral_position_um_;
  const PathSummary np = check_path(nf, label, normal_fresh, normal_measured, normal_, duration);
  const PathSummary lp = check_path(lf, label, lateral_fresh, lateral_measured, lateral_, duration);
  const bool paths_ok = np.ok && lp.ok;

  // Normal axis limits.
  Range normal_force_un = np.extent;
  if (normal_force_mode) {
    if (!(np.extent.lo >= 0) || !(np.extent.hi <= max_n_un)) {
      error(at + ".normal.end_uN" , label + ": normal force path " + range_text(np.extent, "µN") +
                                        " is outside the normal force range [0, " + fmt(max_n_un) + "] µN");
      if (nf.begin && !(*nf.begin >= 0 && *nf.begin <= max_n_un)) result_.errors.back().field = at + ".normal.begin_uN";
    } else {
      const DriveAssessment a = assess_drive(normal_axis_, np.extent.hi * kMicro, 0.0, 0.0);
      if (a.active_voltage_v > normal_axis_.max_drive_v) {
        error(at + ".normal.end_uN", label + ": a normal drive of " + fmt(np.extent.hi) + " µN needs " +
                                         fmt(a.active_voltage_v) + " V, above the amplifier's " +
                                         fmt(normal_axis_.max_drive_v) + " V");
      }
    }
  } else {
    normal_force_un = {0, max_n_un};  // the contact force is whatever the displacement makes
    if (!(np.extent.max_abs() <= max_nx_um)) {
      error(at + ".normal.end_um", label + ": normal displacement path " + range_text(np.extent, "µm") +
                                       " exceeds the normal travel ±" + fmt(max_nx_um) + " µm");
    }
  }
  const bool loaded = normal_force_un.hi > 0;

  // Lateral axis limits.
  Range position_um = lp.extent;
  if (lateral_force_mode) {
    const double excursion = seg.lateral().max_excursion_um();
    if (!(excursion > 0) || !(excursion <= 2 * max_x_um)) {
      error(at + ".lateral.max_excursion_um",
            label + ": LATERAL_FORCE needs lateral.max_excursion_um in (0, " + fmt(2 * max_x_um) +
                "] µm (the break-away hold), got " + fmt(excursion) + " µm");
    }
    position_um = lateral_position_um_.widened(excursion);
    if (!(lp.extent.max_abs() <= max_lf_un)) {
      error(at + ".lateral.end_uN", label + ": lateral force path " + range_text(lp.extent, "µN") +
                                        " exceeds the lateral force limit ±" + fmt(max_lf_un) + " µN");
    }
  } else if (seg.lateral().max_excursion_um() != 0) {
    error(at + ".lateral.max_excursion_um", label + ": max_excursion_um applies to LATERAL_FORCE only");
  }
  if (!(position_um.max_abs() <= max_x_um)) {
    error(at + (lateral_force_mode ? ".lateral.max_excursion_um" : ".lateral.end_um"),
          label + ": lateral path " + range_text(position_um, "µm") + " is outside the lateral travel [-" +
              fmt(max_x_um) + ", " + fmt(max_x_um) + "] µm");
    if (!lateral_force_mode && lf.begin && !(std::fabs(*lf.begin) <= max_x_um)) {
      result_.errors.back().field = at + ".lateral.begin_um";
    }
  }

  // Velocity and acceleration of the lateral displacement.
  if (!lateral_force_mode && paths_ok) {
    const double max_v = lim.max_velocity_m_per_s() / kMicro;
    const double min_v = lim.min_velocity_m_per_s() / kMicro;
    const bool allow = lim.allow_velocity_outside_range();
    const std::string field = at + (speed != 0 ? ".lateral.speed_um_per_s" : ".lateral.end_um");
    const double v = lp.nominal_rate;
    const bool sine = lateral_shape == Shape::kSine;
    if (lp.max_rate > max_v) {
      const std::string text = label + ": lateral velocity " + fmt(lp.max_rate) +
                               " µm/s exceeds the maximum " + fmt(max_v) + " µm/s";
      if (allow) result_.warnings.push_back(text); else error(field, text);
    } else if (loaded && !sine && v > 0 && v < min_v) {
      const std::string text = label + ": loaded lateral velocity " + fmt(v) +
                               " µm/s is below the minimum " + fmt(min_v) + " µm/s";
      if (allow) result_.warnings.push_back(text); else error(field, text);
    } else if (loaded && !sine && v > 0 && v < kWarnVelocityUmPerS) {
      result_.warnings.push_back(label + ": loaded lateral velocity " + fmt(v) +
                                 " µm/s is below 0.2 µm/s, where friction data are unreliable");
    }
    const double max_a = config_.supervisor().max_lateral_acceleration_m_per_s2() / kMicro;
    if (lp.max_acceleration > max_a) {
      error(at + ".lateral", label + ": lateral path acceleration " + fmt(lp.max_acceleration) +
                                 " µm/s² exceeds the supervisor's limit " + fmt(max_a) + " µm/s²");
    }
  }

  // The breakpoint at x = 0: loaded motion stays on one side (§3.2.5).
  const double guard_um = lim.breakpoint_guard_m() / kMicro;
  if (loaded && position_um.lo <= guard_um && position_um.hi >= -guard_um) {
    error(at + ".lateral", label + ": loaded lateral path " + range_text(position_um, "µm") +
                               " comes within " + fmt(guard_um) +
                               " µm of the breakpoint at 0 µm; keep loaded segments on one side of it");
  }

  // Pull-in margin of the lateral drive along the path.
  if (paths_ok && position_um.max_abs() <= max_x_um) {
    const double friction_un = lim.planning_friction_coeff() * normal_force_un.hi;
    const Range extra = lateral_force_mode ? lp.extent : Range{-friction_un, friction_un};
    check_lateral_pull_in(label, at + ".lateral", position_um, extra);
  }

  // Friction compensation: the segment's own, or the protocol's.
  const int model = segment_friction_model(seg, at, label, lateral_force_mode);
  if (model >= 0) {
    check_compensation_bound(model, seg.has_friction_compensation() ? at + ".friction_compensation" : protocol_friction_field_,
                             label, normal_force_un.hi, lp.max_rate, result_.duration_s + duration);
  }

  // Compile.
  SegmentPlan plan;
  plan.name = e.name;
  plan.start_tick = next_tick_;
  plan.tick_count = ticks;
  plan.ticks_per_sample = static_cast<std::uint32_t>(ticks_per_sample);
  plan.normal_mode = normal_mode == v1::NORMAL_CLOSED_LOOP_FORCE ? NormalMode::kClosedLoopForce
                     : normal_mode == v1::NORMAL_DISPLACEMENT    ? NormalMode::kDisplacement
                                                                 : NormalMode::kOpenLoopForce;
  plan.lateral_mode = lateral_force_mode ? LateralMode::kForce : LateralMode::kDisplacement;
  const auto to_si = [](AxisPath p) {
    p.begin *= kMicro;
    p.end *= kMicro;
    p.sine_amplitude_begin *= kMicro;
    p.sine_amplitude_end *= kMicro;
    p.rate_begin *= kMicro;
    p.rate_end *= kMicro;
    return p;
  };
  plan.normal = to_si(np.plan);
  plan.lateral = to_si(lp.plan);
  plan.max_excursion_m = seg.lateral().max_excursion_um() * kMicro;
  plan.friction_model = model;
  plans_.push_back(std::move(plan));
  next_tick_ += ticks;
  result_.duration_s += duration;

  // What follows knows where this segment leaves the axes.
  normal_ = {normal_mode, np.end};
  lateral_ = {lateral_mode, lp.end};
  if (normal_mode == v1::NORMAL_DISPLACEMENT) {
    normal_drive_un_ = {0, max_n_un};
  } else {
    normal_drive_un_ = np.end;
  }
  lateral_position_um_ = lateral_force_mode ? position_um : lp.end;
  first_ = false;
}

ProtocolCheck Checker::run(const v1::Protocol& protocol) {
  // Every number finite, every string bounded, before any arithmetic on them.
  for (auto& issue : check_field_bounds(protocol, "", kMaxErrors)) {
    error(std::move(issue.field), std::move(issue.message));
  }
  if (!result_.errors.empty()) return std::move(result_);
  if (is_set_rate(protocol.acquisition_rate_hz())) {
    protocol_rate_hz_ = protocol.acquisition_rate_hz();
    if (!(protocol_rate_hz_ > 0)) {
      error("acquisition_rate_hz", "acquisition_rate_hz = " + fmt(protocol_rate_hz_) +
                                       " Hz must be positive (0 or absent: the daemon's default)");
      return std::move(result_);
    }
  } else {
    protocol_rate_hz_ = config_.controller().default_acquisition_rate_hz();
    protocol_rate_field_ = "controller.default_acquisition_rate_hz";
  }
  if (protocol.segments_size() == 0) {
    error("segments", "the protocol has no segments");
    return std::move(result_);
  }
  if (protocol.has_friction_compensation()) {
    protocol_friction_model_ = friction_model(protocol.friction_compensation(), "friction_compensation", "the protocol");
    if (!result_.errors.empty()) return std::move(result_);
  }
  Expansion expansion = expand_protocol(protocol, kMaxSegments);
  for (auto& e : expansion.errors) error(std::move(e.field), std::move(e.message));
  if (!result_.errors.empty()) return std::move(result_);
  for (const ExpandedSegment& e : expansion.segments) {
    segment_ = &e;
    check_segment(e);
    segment_ = nullptr;
  }
  const double max_total = config_.limits().max_protocol_duration_s();
  if (result_.duration_s > max_total) {
    error("segments", "the protocol lasts " + fmt(result_.duration_s) + " s, above the maximum " +
                          fmt(max_total) + " s");
  }
  if (result_.ok()) result_.load_function = LoadFunction(std::move(plans_), loop_hz_, std::move(friction_models_));
  return std::move(result_);
}

}  // namespace

ProtocolCheck validate_protocol(const v1::Protocol& protocol, const v1::DaemonConfig& config) {
  return Checker(config).run(protocol);
}

}  // namespace tribo::daemon
