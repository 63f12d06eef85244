#include "analysis/report/phase_timings.h"

#include <sys/resource.h>

#include <fmt/format.h>

#include <string>

#include "analysis/models/model_fit.h"

namespace tribo::analysis {
namespace {

struct ProcessUsage {
  double cpu_s = 0;
  double peak_mb = 0;
};

ProcessUsage process_usage() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  // ru_maxrss is in kilobytes on Linux.
  return {seconds(u.ru_utime) + seconds(u.ru_stime), static_cast<double>(u.ru_maxrss) / 1024.0};
}

}  // namespace

PhaseTimings::PhaseTimings(std::ostream& out)
    : out_(out), wall_(std::chrono::steady_clock::now()), cpu_s_(process_usage().cpu_s), work_(model_work_done()) {}

void PhaseTimings::mark(std::string_view phase, int index) {
  const auto now = std::chrono::steady_clock::now();
  const ProcessUsage usage = process_usage();
  const std::uint64_t work = model_work_done();
  std::string name(phase);
  if (index >= 0) name += fmt::format(" {}", index);
  out_ << fmt::format("timings: {:<44} wall {:8.2f} s  cpu {:8.2f} s  model work {:9.3g}  peak {:6.0f} MB\n", name,
                      std::chrono::duration<double>(now - wall_).count(), usage.cpu_s - cpu_s_,
                      static_cast<double>(work - work_), usage.peak_mb);
  out_.flush();
  wall_ = now;
  cpu_s_ = usage.cpu_s;
  work_ = work;
}

}  // namespace tribo::analysis
