#include "sim/sensor_model.h"

#include <cmath>

namespace tribo::sim {

double measure(double truth, const ChannelSpec& spec, NoiseSource& noise) {
  double value = truth;
  if (spec.noise_rms > 0) value += spec.noise_rms * noise.gaussian();
  if (spec.resolution > 0) value = spec.resolution * std::nearbyint(value / spec.resolution);
  return value;
}

}  // namespace tribo::sim
