// Creep under a stuck contact, from the holds of minutes
// (the dissertation's Fig. 3.12: about +-300 uN of lateral-force drift over
// 1000 s at 7000 uN, held at rest).
//
// A stuck contact is a spring: when the sample creeps against the tip (or the
// position sensor's zero drifts and the position loop follows it), the tip is
// moved against the sample at the creep speed c while the record's position
// stands still, and the held force changes at
//   dF/dt = -k c,   k = the stuck contact's stiffness (the model's sigma0),
// with the same sign in every hold whatever the held force's. The pass model
// holds a stuck contact's force constant, so this is seen only in holds, and
// only in long ones (0.1 nm/s for 150 s moves a 3.5 uN/nm contact by 53 uN;
// for 8 s by 3 uN, under the 10 uN force floor).
//
// Per hold of at least min_hold_s, after settle_s (the stop's transient): the
// force's slope against time, with its error inflated for the residual's
// autocorrelation (analysis/effects/regression.h). Across the holds, the creep:
//   slope_i = a                 one rate in every hold, or
//   slope_i = a + a' tau_i      a rate changing linearly over the holds
//                               (tau from -1/2 at the first hold to 1/2 at
//                               the last: a creep speed that wanders over
//                               minutes),
// the form chosen by leave-one-hold-out prediction; -a / k is the mean creep
// speed, signed along +x (the sample's motion against the tip). The errors
// come from the holds' scatter about the line (each hold one observation),
// the strength from the joint test of a and a'.
// Mimics, each a reason to refuse the creep (the second named when it is what
// the record shows):
//   - drain: slope_i = b F_i (F_i the hold's mean force), a contact that lets
//     its held force relax towards zero (plain LuGre under position noise,
//     b < 0), predicts the holds' slopes better, one hold left out at a time;
//   - a drift of the force reading: it shifts the later passes by what it
//     shifted the holds (a creep is forgotten once the contact slides). The
//     passes' forces, regressed on an offset and a friction level per load
//     and on the holds' accumulated force change, carry a share of it: 1 for
//     a reading drift, 0 for a creep; the creep needs a share 2 standard
//     errors from 1 and within 2 of 0, the reading drift the reverse.
// Held out: each hold's slope predicted by the creep fitted to the others,
// against the pass model's constant held force; the gain in RMS over the
// holds and the share of that change in holds that improved, gated as a
// candidate is (DiagnosisOptions: min_heldout_gain, min_block_agreement), and
// the strength against min_strength_z.
#pragma once

#include <string>
#include <vector>

#include "analysis/input/measured_series.h"
#include "analysis/motion/motion_segmentation.h"

namespace tribo::analysis {

struct CreepInHoldsOptions {
  double min_hold_s = 60;  // a hold shorter than this is not used
  double settle_s = 10;    // left out at the start of each hold (the stop's transient)
  int min_holds = 4;       // fewer long holds: no assessment
  // Gates, as a candidate's (DiagnosisOptions).
  double min_heldout_gain = 0.02;
  double min_block_agreement = 0.75;
  double min_strength_z = 3.0;
};

struct HoldSlope {
  double start_s = 0, duration_s = 0;
  double mean_force = 0;        // force units of the record
  double slope_per_s = 0;       // force units per second
  double slope_std_error = 0;
  // The force levels off (curvature against the slope, 3 standard errors,
  // over a quarter of the change): the contact reached its friction level.
  bool levels_off = false;
};

// What the holds' drift is: none, a creep under the stuck contact, a drift of
// the force reading (which the passes carry too), or both.
enum class HoldDriftForm { kNone, kCreep, kReading, kCreepAndReading };

struct CreepInHolds {
  std::vector<HoldSlope> holds;
  std::string creep_model;  // "one rate in every hold" or "a rate changing linearly over the holds"
  double creep_rate_per_s = 0, creep_rate_std_error = 0;    // a: the mean over the holds, force units per second
  double creep_trend_per_s = 0, creep_trend_std_error = 0;  // its change from the first hold to the last (linear)
  double strength_z = 0;  // the creep's coefficients against none, as standard errors (joint test when two)
  double drain_per_s = 0, drain_std_error = 0;              // b of the drain alone: 1/s
  // The share of the holds' accumulated force change that the later passes
  // carry (a drift of the force reading: 1; a creep: 0); NaN when too few
  // passes follow the holds.
  double reading_share = 0, reading_share_std_error = 0;
  // The passes' own drift over time (force units per s; NaN as the share):
  // with a share between none and all, the holds' slope is a creep's part
  // plus this rate, and both are named when each stands min_strength_z
  // standard errors from none.
  double reading_rate_per_s = 0, reading_rate_std_error = 0;
  double stiffness_per_m = 0;   // k, force units per metre
  double stiffness_std_error = 0;
  std::string stiffness_source; // dF/dx as the holds settle, or the pass model's sigma0
  // -creep_part / k. creep_part: the mean slope of the holds that do not
  // level off when at least two do and some level off (speed_holds of them),
  // else a (a lower bound when levelling_holds > 0); with a reading drift
  // too, less the passes' drift rate.
  double creep_part_per_s = 0, creep_part_std_error = 0;  // the rate the speed is taken from
  double creep_speed_m_per_s = 0, creep_speed_std_error = 0;
  int levelling_holds = 0;
  int speed_holds = 0;
  // Leave one hold out, against a constant held force: RMS over the holds'
  // settled samples about each hold's mean (force units), and the gain.
  double heldout_rms_before = 0, heldout_rms_after = 0;
  double heldout_gain = 0;
  double block_agreement = 0;
  bool accepted = false;        // form is not kNone
  HoldDriftForm form = HoldDriftForm::kNone;
  std::string verdict;          // the form, or why none, with the numbers
};

// holds is empty when the record has fewer than min_holds long holds
// (verdict says so). The stuck contact's stiffness k is dF/dx while the holds
// settle (the position loop moves the stuck tip by tens of nm after the
// stop), where at least half the long holds move by five position noise
// floors (the pass model's sigma0 came out 25 % high on the default
// instrument's creep run), else model_stiffness_per_m with its fitted error
// (<= 0 or NaN: the speed is not given, the rest is).
CreepInHolds creep_in_holds(const MeasuredSeries& series, const MotionSegmentation& motion,
                            double model_stiffness_per_m, double model_stiffness_std_error,
                            const CreepInHoldsOptions& options = {});

}  // namespace tribo::analysis
