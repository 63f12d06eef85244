// Differential capacitive sensing of the lateral position (Srivastava 2006,
// dissertation §5.1.2, eqs. 22-25):
//
//   C+ = eps0 A / (d+ - x),  C- = eps0 A / (d- + x)
//   dC = C+ - C-              (= 2 eps0 A x / (d^2 - x^2) for d+ = d- = d)
//   V  = (V0 / Cf) dC + (white + low-frequency + drift noise, in volts)
//
// synchronously demodulated (modelled as its ideal gain V0/Cf), digitised by
// an ADC (bits over +- full scale) and linearised by inverting the curve with
// the calibrated geometry. The position noise (Table 3.2) is given in metres
// at the neutral point and turned into volts with the sensitivity there:
//   white:         Gaussian, RMS per loop sample (it dithers the contact in a
//                  fast loop; keep it small -- see config/tribod.textproto)
//   low frequency: a 2nd-order Gauss-Markov process (sim/gauss_markov.h),
//                  the slow part of Table 3.2's 10 nm noise floor, which
//                  the loop follows (3 nm by default: config/tribod.textproto)
//   drift:         the sensor zero moves at drift_m_per_s (thermal drift)
// The controller sees only the linearised reading, never the true x.
#pragma once

#include <cstdint>

#include "sim/gauss_markov.h"
#include "sim/noise_source.h"
#include "sim/parallel_plates.h"

namespace tribo::sim {

struct CapacitiveSensingParams {
  PlateGeometry plates;
  PlateGeometry calibrated;
  double excitation_voltage_v = 0;    // V0
  double feedback_capacitance_f = 0;  // Cf
  unsigned adc_bits = 0;              // 0: no quantisation
  double adc_full_scale_v = 0;
  double white_noise_m = 0;
  double low_frequency_noise_m = 0;
  double low_frequency_corner_hz = 0;
  double drift_m_per_s = 0;
};

double differential_capacitance_f(const PlateGeometry& plates, double x_m);

// d(dC)/dx at x = 0: eps0 A (1 / d+^2 + 1 / d-^2).
double capacitance_slope_f_per_m(const PlateGeometry& plates);

// The linearisation: the x whose demodulated voltage is voltage_v under the
// given geometry and demodulator gain (V0 / Cf). Exact inverse of
// gain * differential_capacitance_f(plates, x) inside the gap.
double position_from_voltage_m(const PlateGeometry& plates, double gain_v_per_f, double voltage_v);

// A bipolar ADC: 2^bits steps of 2 full_scale / 2^bits over +- full_scale.
struct Adc {
  Adc(unsigned bits, double full_scale_v);
  unsigned bits;
  double step_v;
  double top_counts;  // 2^(bits - 1)
};

struct AdcSample {
  std::int64_t counts = 0;
  double voltage_v = 0;  // counts times the step
};

// Rounds to the nearest step and clips to the range; bits = 0 passes through.
AdcSample digitise(double voltage_v, const Adc& adc);

class CapacitivePositionSensor {
 public:
  CapacitivePositionSensor(const CapacitiveSensingParams& p, std::uint64_t white_seed,
                           std::uint64_t low_frequency_seed);

  struct Reading {
    double position_m = 0;  // linearised
    double voltage_v = 0;   // demodulated, before the ADC
    std::int64_t counts = 0;
  };

  // Samples the sensor at the end of a tick of length dt_s ending at time_s.
  Reading sample(double true_position_m, double time_s, double dt_s);

  double gain_v_per_f() const { return gain_; }
  double volts_per_metre() const { return volts_per_metre_; }

 private:
  CapacitiveSensingParams p_;
  Adc adc_;
  double gain_;
  double volts_per_metre_;
  NoiseSource white_;
  SecondOrderGaussMarkov low_frequency_;
};

}  // namespace tribo::sim
