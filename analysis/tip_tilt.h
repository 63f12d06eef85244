// The tip's tilt (§5.2) measured from a run, not taken from the config: a
// tilted tip turns part of the normal load N into a lateral force, so the
// transducer reads F sgn(v) - N tan(theta) while sliding and -N tan(theta)
// at rest under load (tan(theta) > 0: the tilt pushes the tip towards +x).
//
// The estimate uses the loaded holds of the run: segments whose lateral
// setpoint holds still while the normal setpoint holds above zero, and
// before which the tip has not slid under load since it was last unloaded.
// After a scratch the LuGre bristles stay deflected at rest and carry nearly
// the whole friction force, so a hold after sliding reads friction plus
// tilt, not tilt alone. A loading ramp is no hold either: the position loop
// is still pulling the plate the last ~80 nm of the approach to its setpoint
// while the contact builds up, and the bristles keep a force the estimate
// would take for tilt (the standard scratch's ramp gives tan(theta) 30 % low
// and its friction 6 % low). Over the samples
// whose measured normal force is at least half the hold's peak (full
// contact; at light load the ratio is all noise),
//
//   tan(theta) = -sum(lateral force) / sum(normal force).
//
// Its precision is set by the slow position noise the resting tip follows
// (the lateral force wanders by ~10 uN RMS at 1 mN with a correlation of a
// second or so): over seeds 1-8, a 5 s hold at 1000 uN gave 0.0255 +- 0.0038
// (sd) against tan(1.5 deg) = 0.0262. Longer holds average more of it.
//
// Then the friction of a sliding segment is mean(lateral force) sgn(v) +
// sgn(v) N tan(theta). SI units.
#pragma once

#include <cstdint>
#include <optional>

#include "tribo/v1/api.pb.h"

namespace tribo::analysis {

struct TipTiltEstimate {
  double tan_tilt = 0;             // tan(theta), positive towards +x
  std::uint32_t first_segment = 0; // the first loaded rest used
  std::uint32_t holds = 0;         // how many loaded rests were used
  std::uint64_t samples = 0;
  double mean_normal_force_n = 0;  // over those samples
  double mean_lateral_force_n = 0;
};

// nullopt when the run has no loaded hold before sliding.
std::optional<TipTiltEstimate> estimate_tip_tilt(const v1::SampleBlock& samples);

// The same estimate fed one segment at a time, in run order (a client that
// streams a run to disk reads it back a segment at a time): the holds' sums
// and the "slid under load" state carry from segment to segment, so the
// result is bit-identical to estimate_tip_tilt over the whole run.
class TipTiltAccumulator {
 public:
  // One segment span (analysis/segment_spans.h) of b.
  void add(const v1::SampleBlock& b, int first, int last);
  std::optional<TipTiltEstimate> estimate() const;

 private:
  TipTiltEstimate e_;
  double lateral_ = 0, normal_ = 0;
  bool slid_under_load_ = false;  // since the tip was last unloaded
};

// The friction of a sliding segment without the tilt's share:
// mean_friction_n (lateral force x sgn(v)) + sgn(v) N tan(theta).
double tilt_corrected_friction_n(double mean_friction_n, double velocity_m_per_s, double normal_force_n,
                                 double tan_tilt);

}  // namespace tribo::analysis
