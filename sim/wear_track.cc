#include "sim/wear_track.h"

#include <algorithm>
#include <cmath>

namespace tribo::sim {

WearTrack::WearTrack(const WearParams& p) : p_(p) {
  if (p_.enabled) {
    freshness_.assign(static_cast<std::size_t>(std::ceil(2 * kSpan_m / p_.bin_width_m)), 1.0);
  }
}

double WearTrack::factor_at(double x) const {
  if (freshness_.empty()) return 1.0;
  const double bin = std::floor((x + kSpan_m) / p_.bin_width_m);
  if (bin < 0 || bin >= static_cast<double>(freshness_.size())) return 1.0;
  return 1.0 - (1.0 - p_.steady_state_ratio) * (1.0 - freshness_[static_cast<std::size_t>(bin)]);
}

void WearTrack::slide(double from_m, double to_m, double load_n) {
  if (freshness_.empty() || !(load_n > 0) || from_m == to_m) return;
  const double kappa = p_.decay_per_pass * std::pow(load_n / p_.reference_load_n, p_.load_exponent);
  const double lo = std::min(from_m, to_m) + kSpan_m, hi = std::max(from_m, to_m) + kSpan_m;
  const double last = static_cast<double>(freshness_.size()) - 1;
  const double first_bin = std::max(0.0, std::floor(lo / p_.bin_width_m));
  const double last_bin = std::min(last, std::floor(hi / p_.bin_width_m));
  // In the direction of motion, so that the contact ends in the bin it is in.
  const bool forward = to_m > from_m;
  for (double i = 0; i <= last_bin - first_bin; ++i) {
    const double b = forward ? first_bin + i : last_bin - i;
    const double overlap = std::min(hi, (b + 1) * p_.bin_width_m) - std::max(lo, b * p_.bin_width_m);
    if (overlap > 0) book(static_cast<std::size_t>(b), overlap / p_.bin_width_m, kappa);
  }
}

void WearTrack::book(std::size_t bin, double fraction_of_pass, double kappa) {
  if (bin != current_bin_) {
    freshness_[current_bin_] *= std::exp(-pending_);
    current_bin_ = bin;
    pending_ = 0;
  }
  pending_ += kappa * fraction_of_pass;
}

}  // namespace tribo::sim
