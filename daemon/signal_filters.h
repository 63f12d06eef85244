// Small allocation-free filters for the tick path.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace tribo::daemon {

// First-order low-pass, backward Euler: y += a (x - y), a = dt / (Tf + dt),
// Tf = 1 / (2 pi cutoff). Cutoff 0 passes the input through. The first
// sample initialises the output (no start-up transient). Non-finite inputs
// leave the output unchanged.
class LowPass {
 public:
  void configure(double cutoff_hz, double dt_s) {
    const double tf = cutoff_hz > 0 ? 1.0 / (2.0 * std::numbers::pi * cutoff_hz) : 0.0;
    alpha_ = dt_s / (tf + dt_s);
  }
  double update(double x) {
    if (!std::isfinite(x)) return y_;
    y_ = primed_ ? y_ + alpha_ * (x - y_) : x;
    primed_ = true;
    return y_;
  }
  double value() const { return y_; }
  bool primed() const { return primed_; }

 private:
  double alpha_ = 1;
  double y_ = 0;
  bool primed_ = false;
};

// Counts how many consecutive samples were bit-identical to the one before.
class RepeatCounter {
 public:
  std::uint32_t update(double x) {
    repeats_ = (primed_ && x == last_) ? repeats_ + 1 : 0;
    last_ = x;
    primed_ = true;
    return repeats_;
  }
  std::uint32_t count() const { return repeats_; }

 private:
  double last_ = 0;
  std::uint32_t repeats_ = 0;
  bool primed_ = false;
};

}  // namespace tribo::daemon
