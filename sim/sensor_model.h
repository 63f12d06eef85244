// What the simulated transducer reports: the true value plus white Gaussian
// noise (RMS per loop sample, Table 3.2's noise floors) quantised to the
// channel's resolution. Each channel draws from its own NoiseSource.
#pragma once

#include "sim/noise_source.h"

namespace tribo::sim {

struct ChannelSpec {
  double noise_rms = 0;   // 0: no noise
  double resolution = 0;  // 0: no quantisation
};

double measure(double truth, const ChannelSpec& spec, NoiseSource& noise);

struct SensorSpecs {
  ChannelSpec lateral_position_m;
  ChannelSpec lateral_force_n;
  ChannelSpec normal_force_n;
  ChannelSpec normal_displacement_m;
};

}  // namespace tribo::sim
