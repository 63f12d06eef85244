#include "daemon/load_function.h"

#include <cmath>
#include <numbers>

namespace tribo::daemon {

namespace {

double sine_amplitude(const AxisPath& p, double t_s, double duration_s) {
  return p.sine_amplitude_begin + (p.sine_amplitude_end - p.sine_amplitude_begin) * (t_s / duration_s);
}

double normal_measured(NormalMode mode, const MeasuredStart& m) {
  switch (mode) {
    case NormalMode::kOpenLoopForce: return m.normal_drive_n;
    case NormalMode::kClosedLoopForce: return m.normal_force_n;
    case NormalMode::kDisplacement: return m.normal_displacement_m;
  }
  return 0;
}

double lateral_measured(LateralMode mode, const MeasuredStart& m) {
  switch (mode) {
    case LateralMode::kDisplacement: return m.lateral_position_m;
    case LateralMode::kForce: return m.lateral_force_n;
    case LateralMode::kOpenLoopDrive: break;
  }
  return 0;
}

double resolve_begin(const AxisPath& p, double measured, double previous_end) {
  if (p.begin_from_measured) return measured;
  if (p.begin_continues) return previous_end;
  return p.begin;
}

}  // namespace

double path_end(const AxisPath& p, double begin, double duration_s) {
  switch (p.shape) {
    case Shape::kHold: return begin;
    case Shape::kVelocityProfile: return begin + 0.5 * (p.rate_begin + p.rate_end) * duration_s;
    case Shape::kRamp:
    case Shape::kSine: break;
  }
  return p.end_relative ? begin + p.end : p.end;
}

double path_value(const AxisPath& p, double begin, double end, double t_s, double duration_s) {
  // The fraction is divided out only by the shapes that use it (a hold, most
  // ticks of a protocol on the normal axis, needs no division).
  switch (p.shape) {
    case Shape::kHold: return begin;
    case Shape::kRamp: return begin + (end - begin) * (t_s / duration_s);
    case Shape::kSine:
      return begin + (end - begin) * (t_s / duration_s) +
             sine_amplitude(p, t_s, duration_s) *
                 std::sin(2.0 * std::numbers::pi * p.sine_frequency_hz * t_s);
    case Shape::kVelocityProfile:
      return begin + p.rate_begin * t_s + (p.rate_end - p.rate_begin) * t_s * (t_s / duration_s) * 0.5;
  }
  return begin;
}

double path_rate(const AxisPath& p, double begin, double end, double t_s, double duration_s) {
  switch (p.shape) {
    case Shape::kHold: return 0;
    case Shape::kRamp: return (end - begin) / duration_s;
    case Shape::kSine: {
      const double w = 2.0 * std::numbers::pi * p.sine_frequency_hz;
      const double growth = (p.sine_amplitude_end - p.sine_amplitude_begin) / duration_s;
      return (end - begin) / duration_s + growth * std::sin(w * t_s) +
             sine_amplitude(p, t_s, duration_s) * w * std::cos(w * t_s);
    }
    case Shape::kVelocityProfile:
      return p.rate_begin + (p.rate_end - p.rate_begin) * (t_s / duration_s);
  }
  return 0;
}

LoadFunction::LoadFunction(std::vector<SegmentPlan> segments, double loop_rate_hz,
                           std::vector<FrictionReport> friction_models)
    : segments_(std::move(segments)), friction_models_(std::move(friction_models)), loop_rate_hz_(loop_rate_hz) {
  for (const SegmentPlan& s : segments_) total_ticks_ += s.tick_count;
}

std::uint64_t LoadFunction::expected_samples() const {
  std::uint64_t samples = 0;
  for (const SegmentPlan& s : segments_) samples += s.tick_count / s.ticks_per_sample;
  return samples;
}

void SegmentRunner::enter(std::size_t index, const MeasuredStart& measured) {
  const SegmentPlan& s = lf_.segments()[index];
  duration_s_ = static_cast<double>(s.tick_count) / lf_.loop_rate_hz();
  normal_begin_ = resolve_begin(s.normal, normal_measured(s.normal_mode, measured), normal_end_);
  normal_end_ = path_end(s.normal, normal_begin_, duration_s_);
  lateral_begin_ = resolve_begin(s.lateral, lateral_measured(s.lateral_mode, measured), lateral_end_);
  lateral_end_ = path_end(s.lateral, lateral_begin_, duration_s_);
  cursor_ = index;
  entered_ = true;
}

TickSetpoints SegmentRunner::at(std::uint64_t tick, const MeasuredStart& measured) {
  const auto& segments = lf_.segments();
  bool start = false;
  if (!entered_) {
    enter(0, measured);
    start = true;
  }
  while (cursor_ + 1 < segments.size() &&
         tick >= segments[cursor_].start_tick + segments[cursor_].tick_count) {
    enter(cursor_ + 1, measured);
    start = true;
  }
  const SegmentPlan& s = segments[cursor_];
  // Begin at the segment's first tick, end at the next segment's first tick.
  const double t = static_cast<double>(tick - s.start_tick) / lf_.loop_rate_hz();
  TickSetpoints sp;
  sp.segment = static_cast<std::uint32_t>(cursor_);
  sp.ticks_per_sample = s.ticks_per_sample;
  sp.normal_mode = s.normal_mode;
  sp.normal = path_value(s.normal, normal_begin_, normal_end_, t, duration_s_);
  sp.lateral_mode = s.lateral_mode;
  sp.lateral = path_value(s.lateral, lateral_begin_, lateral_end_, t, duration_s_);
  sp.lateral_rate = path_rate(s.lateral, lateral_begin_, lateral_end_, t, duration_s_);
  sp.max_excursion_m = s.max_excursion_m;
  sp.segment_start = start;
  if (s.friction_model >= 0) sp.friction_model = &lf_.friction_models()[static_cast<std::size_t>(s.friction_model)].model;
  return sp;
}

}  // namespace tribo::daemon
