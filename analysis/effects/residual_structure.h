// What a final residual still follows when it stands above its white-noise
// floor: the regressor (distance since the pass began or since a speed
// change, time, position, speed, acceleration, load) whose binned means
// explain most of its variance, for the report's "unexplained" line.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {

// Over the samples the model answers for (compared != 0: with the state from
// rest the holds are not modelled, and their residual is not structure
// left). nullopt when the residual's RMS is below 1.5 times noise.
std::optional<std::string> describe_residual_structure(const ModelData& data, const std::vector<double>& residual,
                                                       const std::vector<char>& compared, double noise);

}  // namespace tribo::analysis
