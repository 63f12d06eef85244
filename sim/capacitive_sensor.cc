#include "sim/capacitive_sensor.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

double differential_capacitance_f(const PlateGeometry& p, double x) {
  const double eps_a = kVacuumPermittivity_f_per_m * p.area_m2;
  return eps_a / (p.gap_positive_m - x) - eps_a / (p.gap_negative_m + x);
}

double capacitance_slope_f_per_m(const PlateGeometry& p) {
  return kVacuumPermittivity_f_per_m * p.area_m2 *
         (1.0 / (p.gap_positive_m * p.gap_positive_m) + 1.0 / (p.gap_negative_m * p.gap_negative_m));
}

double position_from_voltage_m(const PlateGeometry& p, double gain, double voltage_v) {
  // q = V / (gain eps0 A) = 1/(a - x) - 1/(b + x)  <=>  q x^2 + (2 - q (a - b)) x + (b - a) - q a b = 0,
  // whose root inside (-b, a) is taken in the cancellation-free form.
  const double a = p.gap_positive_m, b = p.gap_negative_m;
  const double q = voltage_v / (gain * kVacuumPermittivity_f_per_m * p.area_m2);
  const double lin = 2.0 - q * (a - b);
  const double c = (b - a) - q * a * b;
  return -2.0 * c / (lin + std::sqrt(lin * lin - 4.0 * q * c));
}

Adc::Adc(unsigned b, double full_scale_v)
    : bits(b),
      step_v(b > 0 ? 2.0 * full_scale_v / std::ldexp(1.0, static_cast<int>(b)) : 0.0),
      top_counts(b > 0 ? std::ldexp(1.0, static_cast<int>(b) - 1) : 0.0) {}

AdcSample digitise(double voltage_v, const Adc& adc) {
  if (adc.bits == 0) return AdcSample{0, voltage_v};
  const double counts = std::clamp(std::nearbyint(voltage_v / adc.step_v), -adc.top_counts, adc.top_counts - 1);
  return AdcSample{static_cast<std::int64_t>(counts), counts * adc.step_v};
}

CapacitivePositionSensor::CapacitivePositionSensor(const CapacitiveSensingParams& p,
                                                   std::uint64_t white_seed,
                                                   std::uint64_t low_frequency_seed)
    : p_(p),
      adc_(p.adc_bits, p.adc_full_scale_v),
      gain_(p.excitation_voltage_v / p.feedback_capacitance_f),
      volts_per_metre_(gain_ * capacitance_slope_f_per_m(p.plates)),
      white_(white_seed),
      low_frequency_(p.low_frequency_noise_m, p.low_frequency_corner_hz, low_frequency_seed) {}

CapacitivePositionSensor::Reading CapacitivePositionSensor::sample(double x, double time_s,
                                                                   double dt_s) {
  double noise_m = p_.drift_m_per_s * time_s + low_frequency_.advance(dt_s);
  if (p_.white_noise_m > 0) noise_m += p_.white_noise_m * white_.gaussian();
  const double voltage = gain_ * differential_capacitance_f(p_.plates, x) + volts_per_metre_ * noise_m;
  const AdcSample adc = digitise(voltage, adc_);
  return Reading{position_from_voltage_m(p_.calibrated, gain_, adc.voltage_v), voltage, adc.counts};
}

}  // namespace tribo::sim
