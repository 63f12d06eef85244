// The channels outside the lateral position loop: the true value plus white
// Gaussian noise (RMS per loop sample, Table 3.2's noise floors) quantised to
// the channel's resolution. Each channel draws from its own NoiseSource. (The
// lateral position, which closes the loop, goes through the capacitive
// sensing chain of sim/capacitive_sensor.h.)
#pragma once

#include "sim/noise_source.h"

namespace tribo::sim {

struct ChannelSpec {
  double noise_rms = 0;   // 0: no noise
  double resolution = 0;  // 0: no quantisation
};

double measure(double truth, const ChannelSpec& spec, NoiseSource& noise);

struct SensorSpecs {
  ChannelSpec lateral_force_n;
  ChannelSpec normal_force_n;
  ChannelSpec normal_displacement_m;
  double normal_displacement_drift_m_per_s = 0;  // thermal drift of the Z sensor's zero
  // White readout noise of the recorded lateral position, RMS per loop
  // sample: the acquisition chain adds it to the record, after the point
  // where the position loop takes its reading (Table 3.2's 10 nm floor;
  // docs/simulated_instrument.md, "Sensors at Table 3.2's floors"). 0: none.
  double lateral_position_record_noise_m = 0;
};

}  // namespace tribo::sim
