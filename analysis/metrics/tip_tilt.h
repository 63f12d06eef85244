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
#include <vector>

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
  // One segment span (analysis/metrics/segment_spans.h) of b.
  void add(const v1::SampleBlock& b, int first, int last);
  std::optional<TipTiltEstimate> estimate() const;

 private:
  TipTiltEstimate e_;
  double lateral_ = 0, normal_ = 0;
  bool slid_under_load_ = false;  // since the tip was last unloaded
};

// The tilt from passes both ways (§5.2): towards +x the transducer reads
// friction less N tan(theta), towards -x friction plus it, so on a contact
// whose friction is the same both ways half the difference of the two
// directions' friction coefficients is the tilt:
//
//   tan(theta) = (mean mu of the -x passes - mean mu of the +x passes) / 2,
//
// mu = mean_friction / N of a pass's steady window (friction: the reading
// times sgn(v)). Friction moves with speed and load, so passes are paired
// only with passes of the same speed (within 1 %) and normal force (within
// 5 %): each such set with passes both ways gives one value, and the
// estimate is their mean weighted by the passes in each. Unlike a hold, it
// does not depend on how much of the tilt's push the contact holds at rest.
struct PassFriction {
  double velocity_m_per_s = 0;  // commanded, signed
  double normal_force_n = 0;
  double mean_friction_n = 0;   // reading x sgn(v), steady window
};

struct PassesTiltEstimate {
  double tan_tilt = 0;
  std::uint32_t forward_passes = 0;   // +x passes used
  std::uint32_t backward_passes = 0;  // -x passes used
};

// nullopt when no speed and load was slid both ways.
std::optional<PassesTiltEstimate> estimate_tilt_from_passes(const std::vector<PassFriction>& passes);

// A hold's estimate agrees with the passes' when they differ by at most
// twice the hold's own scatter on a contact that gives way (sd 0.0038 over
// seeds 1-8 of a 5 s hold at 1000 uN, above). On a contact that holds a
// force at rest the hold reads less than the tilt and disagrees.
inline constexpr double kHoldTiltAgreement = 2 * 0.0038;
bool hold_tilt_agrees(double hold_tan_tilt, double passes_tan_tilt);

// The friction of a sliding segment without the tilt's share:
// mean_friction_n (lateral force x sgn(v)) + sgn(v) N tan(theta).
double tilt_corrected_friction_n(double mean_friction_n, double velocity_m_per_s, double normal_force_n,
                                 double tan_tilt);

}  // namespace tribo::analysis
