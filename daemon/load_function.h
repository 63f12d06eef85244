// A validated protocol compiled into tick ranges: repeat blocks unrolled,
// units SI, every segment a plan per axis (mode and setpoint path). The
// setpoints of a tick are a cheap function of the tick number; a
// SegmentRunner walks the plan during a run without allocating, resolving the
// begins that depend on the instrument (first segment, change of mode) from
// the measured values at the segment's first tick.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "daemon/friction_report.h"

namespace tribo::daemon {

enum class NormalMode : std::uint8_t { kOpenLoopForce, kClosedLoopForce, kDisplacement };
// kOpenLoopDrive: the lateral drive force itself (N); only the safe stop
// sequence uses it, when the position reading cannot be trusted.
enum class LateralMode : std::uint8_t { kDisplacement, kForce, kOpenLoopDrive };
enum class Shape : std::uint8_t { kRamp, kHold, kSine, kVelocityProfile };

// The setpoint path of one axis within one segment, in the SI unit of its
// mode (N or m). t runs from 0 to the segment's duration T.
struct AxisPath {
  Shape shape = Shape::kRamp;
  bool begin_from_measured = false;  // resolved at the segment's first tick
  bool begin_continues = false;      // the previous segment's actual end
  double begin = 0;                  // when neither of the above
  bool end_relative = false;         // end = begin + delta
  double end = 0;                    // absolute end, or the delta
  double sine_frequency_hz = 0;
  double sine_amplitude_begin = 0;
  double sine_amplitude_end = 0;
  double rate_begin = 0;             // VELOCITY_PROFILE, unit per second
  double rate_end = 0;
};

// The end of a path that starts at begin and lasts duration_s.
double path_end(const AxisPath& path, double begin, double duration_s);
// The setpoint at time t of a path from begin to end (path_end's result).
double path_value(const AxisPath& path, double begin, double end, double t_s, double duration_s);
// Its rate of change (unit per second) at time t.
double path_rate(const AxisPath& path, double begin, double end, double t_s, double duration_s);

struct SegmentPlan {
  std::string name;  // with the pass, e.g. "scratch (pass 2/6)"
  std::uint64_t start_tick = 0;
  std::uint64_t tick_count = 0;
  std::uint32_t ticks_per_sample = 1;  // loop rate / acquisition rate
  NormalMode normal_mode = NormalMode::kOpenLoopForce;
  AxisPath normal;
  LateralMode lateral_mode = LateralMode::kDisplacement;
  AxisPath lateral;
  double max_excursion_m = 0;  // LATERAL_FORCE: hold once moved this far
  // The friction model the lateral displacement loop compensates with: an
  // index into LoadFunction::friction_models(), -1 for none.
  int friction_model = -1;
};

class LoadFunction {
 public:
  LoadFunction() = default;
  LoadFunction(std::vector<SegmentPlan> segments, double loop_rate_hz,
               std::vector<FrictionReport> friction_models = {});

  std::uint64_t total_ticks() const { return total_ticks_; }
  // The identified friction models the segments compensate with (SegmentPlan::friction_model).
  const std::vector<FrictionReport>& friction_models() const { return friction_models_; }
  double loop_rate_hz() const { return loop_rate_hz_; }
  const std::vector<SegmentPlan>& segments() const { return segments_; }
  std::uint64_t expected_samples() const;

 private:
  std::vector<SegmentPlan> segments_;
  std::vector<FrictionReport> friction_models_;
  std::uint64_t total_ticks_ = 0;
  double loop_rate_hz_ = 0;
};

// The values an absent begin resolves to, in the unit of the axis mode (the
// run loop passes low-passed forces, the contact force clamped at 0).
struct MeasuredStart {
  double normal_drive_n = 0;  // last commanded normal drive (open loop)
  double normal_force_n = 0;
  double normal_displacement_m = 0;
  double lateral_position_m = 0;
  double lateral_force_n = 0;
};

struct TickSetpoints {
  std::uint32_t segment = 0;
  std::uint32_t ticks_per_sample = 1;
  NormalMode normal_mode = NormalMode::kOpenLoopForce;
  double normal = 0;        // N (force modes) or m (displacement)
  LateralMode lateral_mode = LateralMode::kDisplacement;
  double lateral = 0;       // m (displacement) or N (force)
  double lateral_rate = 0;  // unit per second
  double max_excursion_m = 0;
  bool segment_start = false;  // first tick of a segment
  // The model the lateral displacement loop compensates friction with
  // (daemon/friction_observer.h); null: no compensation.
  const IdentifiedFriction* friction_model = nullptr;
};

// Walks a LoadFunction tick by tick. Not thread-safe; allocation-free.
class SegmentRunner {
 public:
  explicit SegmentRunner(const LoadFunction& load_function) : lf_(load_function) {}

  bool finished(std::uint64_t tick) const { return tick >= lf_.total_ticks(); }

  // Setpoints at tick (< total_ticks, called with consecutive ticks).
  // measured is read only on a segment's first tick.
  TickSetpoints at(std::uint64_t tick, const MeasuredStart& measured);

 private:
  void enter(std::size_t index, const MeasuredStart& measured);

  const LoadFunction& lf_;
  std::size_t cursor_ = 0;
  bool entered_ = false;
  double normal_begin_ = 0, normal_end_ = 0;
  double lateral_begin_ = 0, lateral_end_ = 0;
  double duration_s_ = 0;
};

}  // namespace tribo::daemon
