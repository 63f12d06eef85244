// Repeated scratching reaching a steady state (dissertation §4.4: about 6
// passes at 500 uN, 3 at 5000 uN; a reverse pass after a forward one gives
// lower friction). The track on the sample is cut into bins; each keeps its
// freshness phi in (0, 1], 1 for untouched surface. Every pass of the contact
// centre over a bin multiplies phi by exp(-kappa(N)), spread over the bin in
// proportion to the distance slid in it, and the friction levels there scale
// by
//
//   W = 1 - (1 - steady_state_ratio) (1 - phi),   kappa(N) = decay_per_pass (N / N_ref)^p
//
// so the friction relaxes geometrically from its fresh value to
// steady_state_ratio times it, faster at higher loads for p > 0. A bin's
// wear is booked when the contact leaves it, so a pass feels the surface as
// the earlier passes left it. Outside the tracked span (+-50 um on the
// sample) the surface stays fresh.
#pragma once

#include <vector>

namespace tribo::sim {

struct WearParams {
  bool enabled = false;
  double steady_state_ratio = 1;
  double decay_per_pass = 0;
  double reference_load_n = 1;
  double load_exponent = 0;
  double bin_width_m = 0.25e-6;
};

class WearTrack {
 public:
  explicit WearTrack(const WearParams& p);

  // W at a position on the sample (1 when wear is off).
  double factor_at(double sample_position_m) const;
  // The contact centre slid from `from` to `to` under load N.
  void slide(double from_m, double to_m, double load_n);

  static constexpr double kSpan_m = 50e-6;

 private:
  void book(std::size_t bin, double fraction_of_pass, double kappa);

  WearParams p_;
  std::vector<double> freshness_;
  // Sliding in the bin under the contact, booked when the contact leaves it.
  std::size_t current_bin_ = 0;
  double pending_ = 0;  // sum of kappa * distance / bin width
};

}  // namespace tribo::sim
