// Where an identification spends its time (tribo-fit diagnose --timings):
// one line per phase on a stream, with the phase's wall and CPU time (the
// process's, every thread), the model work done in it (Jacobian rows times
// columns over every fit's model evaluations, model_work_done(),
// analysis/models/model_fit.h) and the process's peak resident memory so
// far. The cost of a record can then be followed phase by phase on any
// record and build, without a profiler (docs/identification.md, "Cost").
#pragma once

#include <chrono>
#include <cstdint>
#include <ostream>
#include <string_view>

namespace tribo::analysis {

class PhaseTimings {
 public:
  explicit PhaseTimings(std::ostream& out);
  // The phase that ends now; index >= 0 is appended to its name (a round's).
  void mark(std::string_view phase, int index = -1);

 private:
  std::ostream& out_;
  std::chrono::steady_clock::time_point wall_;
  double cpu_s_ = 0;
  std::uint64_t work_ = 0;
};

// Marks the phase on timings, if there are any (the diagnosis' options and
// requests hold a null pointer unless asked).
inline void mark_phase(PhaseTimings* timings, std::string_view phase, int index = -1) {
  if (timings) timings->mark(phase, index);
}

}  // namespace tribo::analysis
