// A pure delay of a fixed number of ticks for the tick path: the storage is
// allocated once, when the line is made (from the config), never by push or
// fill. Zero ticks passes the input through.
#pragma once

#include <cstddef>
#include <vector>

namespace tribo::daemon {

class DelayLine {
 public:
  DelayLine() = default;
  explicit DelayLine(std::size_t ticks) : buffer_(ticks, 0.0) {}

  std::size_t ticks() const { return buffer_.size(); }

  // Returns the value pushed `ticks()` calls ago (the fill value until then)
  // and stores x in its place.
  double push(double x) {
    if (buffer_.empty()) return x;
    const double out = buffer_[next_];
    buffer_[next_] = x;
    next_ = next_ + 1 == buffer_.size() ? 0 : next_ + 1;
    return out;
  }

  // Every stored value becomes `value`, as if it had been pushed for ticks() calls.
  void fill(double value) {
    for (double& v : buffer_) v = value;
    next_ = 0;
  }

 private:
  std::vector<double> buffer_;
  std::size_t next_ = 0;
};

}  // namespace tribo::daemon
