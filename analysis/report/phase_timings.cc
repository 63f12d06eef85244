#include "analysis/report/phase_timings.h"

#include <sys/resource.h>

#include <fmt/format.h>

#include <iterator>

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
  // ru_maxrss is in KiB on Linux; MB here are 10^6 bytes, as the record
  // benchmark's (bench/diagnose_record_bench.py).
  return {seconds(u.ru_utime) + seconds(u.ru_stime), static_cast<double>(u.ru_maxrss) * 1024.0 / 1e6};
}

}  // namespace

PhaseTimings::PhaseTimings(std::ostream& out)
    : out_(out), wall_(std::chrono::steady_clock::now()), cpu_s_(process_usage().cpu_s), work_(model_work_done()) {}

void PhaseTimings::mark(std::string_view phase, int index) {
  const auto now = std::chrono::steady_clock::now();
  const ProcessUsage usage = process_usage();
  const std::uint64_t work = model_work_done();
  // Formatted in buffers on the stack: a mark allocates nothing, so asking
  // for the timings leaves the heap whose peak they report as it would be.
  fmt::memory_buffer name;
  fmt::format_to(std::back_inserter(name), "{}", phase);
  if (index >= 0) fmt::format_to(std::back_inserter(name), " {}", index);
  fmt::memory_buffer line;
  fmt::format_to(std::back_inserter(line), "timings: {:<44} wall {:8.2f} s  cpu {:8.2f} s  model work {:9.3g}  peak {:6.0f} MB\n",
                 fmt::string_view(name.data(), name.size()), std::chrono::duration<double>(now - wall_).count(),
                 usage.cpu_s - cpu_s_, static_cast<double>(work - work_), usage.peak_mb);
  out_.write(line.data(), static_cast<std::streamsize>(line.size()));
  out_.flush();
  wall_ = now;
  cpu_s_ = usage.cpu_s;
  work_ = work;
}

}  // namespace tribo::analysis
