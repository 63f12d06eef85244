// How many knot intervals the drift spline gets, chosen by the record.
// A fixed count (one interval per two passes) either follows the noise
// of a record without drift or, with the knots at quantiles of the fitted
// samples, leaves long intervals over the held-out passes between them, where
// a drift that wanders (the independent generator's 60 s wobble) is then
// interpolated badly, and a direction asymmetry fits the held-out passes
// better than the drift does.
//
// The count is chosen as a regression spline's usually is, by cross-
// validation, on the fit samples only (the held-out passes stay the gate's):
// the base model's residual is regressed on the drift spline (linear least
// squares, the base parameters held), each fitted pass left out in turn and
// predicted from the others; the fewest intervals whose mean squared
// prediction error lies within one standard error of the least (the
// one-standard-error rule) win. Leaving out a whole pass asks what the held-out gate asks of a
// drift: to carry it across a pass it has not seen.
#pragma once

#include <utility>
#include <vector>

#include "analysis/models/friction_model.h"

namespace tribo::analysis {

struct DriftKnotChoice {
  int intervals = 0;                              // chosen (set in the ModelData)
  int default_intervals = 0;                      // one per two passes, 3 to 12
  std::vector<std::pair<int, double>> cv_rms;     // (intervals, RMS of the left-out passes' prediction error)
};

// Tries 3 to the default count of intervals on data and leaves the chosen
// one set. residual: measured minus the base model's force at every sample;
// in_fit: the fit samples (those in a pass are the folds).
DriftKnotChoice choose_drift_intervals(ModelData& data, const std::vector<double>& residual,
                                       const std::vector<char>& in_fit);

}  // namespace tribo::analysis
