// Whether an accepted effect is told apart from its nearest rivals at the
// record's noise: the confusion check. Another effect of the vocabulary may
// leave nearly the same change of the model force on this record's motion
// (a log-velocity strengthening and the direct effect of rate-and-state
// friction on a record without speed steps), and the held-out gates then
// accept whichever is tried first.
//
// Method (the visible part of analysis/effects/detectability.h, asked of an
// effect the diagnosis accepted, against each rival's extension):
//   d_X  = model(final) - model(final without X), on the fit rows;
//   r_X  = d_X less its least-squares projection on the Jacobian of the model
//          without X (what a refit of that model's parameters absorbs);
//   for each rival Y, its extension's Jacobian (base + Y's parameters at
//          their starting values, linearised at the model without X), and
//          r_X less its projection on [J_base, J_Y] (Gauss-Newton's first
//          step of the rival's fit to X's force);
//   z_XY = sqrt(n_eff) ||r_X - P_Y r_X|| / (sigma sqrt(m)) over m subsampled
//          fit rows, in the units of the strength gate (min_strength_z), and
//          the share of r_X's power the rival takes up.
// z_X (no rival) is what X would show alone; the nearest rival is the one
// with the smallest z_XY. A rival whose parameters start at a neutral value
// contributes only the directions its force has there (rate_state's D_c and
// dwell stiction's time scales are linearised at their start values).
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "analysis/effects/detectability.h"
#include "analysis/effects/effect.h"
#include "analysis/models/friction_model.h"
#include "analysis/models/model_fit.h"

namespace tribo::analysis {

struct RivalConfusion {
  Effect rival = Effect::kDrift;
  // What the rival's extension leaves of the effect's visible part, in units
  // of the strength gate; NaN when the rival's extension could not be formed.
  double z = std::numeric_limits<double>::quiet_NaN();
  double explained = std::numeric_limits<double>::quiet_NaN();  // share of the visible part's power it takes up
};

struct EffectConfusion {
  double z_alone = std::numeric_limits<double>::quiet_NaN();  // the visible part's own z
  std::vector<RivalConfusion> rivals;  // smallest z first (NaN last): front() is the nearest
  // The z the nearest rival must leave for the effect to be called
  // distinguishable (the diagnosis sets it: its confusion gate, or else the
  // strength gate's min_strength_z).
  double z_needed = 3.0;
  bool distinguishable() const { return rivals.empty() || std::isnan(rivals.front().z) || rivals.front().z >= z_needed; }
};

// effect must be in final_fit's model; rivals not in it (others are skipped).
// final_model: the final model's force per sample; rows from visible_rows()
// on it. Rivals are examined on up to `threads` threads (0: one per core).
EffectConfusion confusion_with_rivals(const ModelData& data, const FitResult& final_fit,
                                      const std::vector<double>& final_model, const VisibleRows& rows, Effect effect,
                                      const std::vector<Effect>& rivals, unsigned threads = 1);

}  // namespace tribo::analysis
