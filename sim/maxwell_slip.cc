#include "sim/maxwell_slip.h"

namespace tribo::sim {

double slip_share(const PreslidingHysteresisParams& p, int i) {
  if (p.elements <= 1) return 1.0;
  return 1.0 + p.spread * (2.0 * i / (p.elements - 1) - 1.0);
}

}  // namespace tribo::sim
