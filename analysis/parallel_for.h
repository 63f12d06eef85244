// Independent jobs on the machine's cores: the diagnosis fits each round's
// candidates at once (they share only read-only data). fn(j) must write only
// its own slot j, so the result does not depend on the schedule.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace tribo::analysis {

// The jobs running now on parallel_for's threads, over all its calls, and
// whether this thread is one of them.
inline std::atomic<unsigned> running_jobs{0};
inline thread_local bool on_job_thread = false;

// The cores that no parallel_for job but the caller's own is running on
// now, at least 1 (the caller's): work whose result does not depend on how
// it is split (the fits' simulation in pieces) takes the cores the others
// leave idle.
inline unsigned cores_free_for_caller() {
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const unsigned others = running_jobs.load(std::memory_order_relaxed) - (on_job_thread ? 1u : 0u);
  return others + 1 >= cores ? 1u : cores - others;
}

// Calls fn(j) for j in [0, count) on up to `threads` threads (0: one per
// core); returns when all are done. The first exception thrown is rethrown.
template <class Fn>
void parallel_for(std::size_t count, unsigned threads, Fn fn) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t workers = std::min<std::size_t>(count, threads);
  if (workers <= 1) {
    for (std::size_t j = 0; j < count; ++j) fn(j);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors(count);
  {
    std::vector<std::jthread> pool;
    for (std::size_t w = 0; w < workers; ++w) {
      pool.emplace_back([&] {
        on_job_thread = true;
        for (std::size_t j = next++; j < count; j = next++) {
          ++running_jobs;
          try {
            fn(j);
          } catch (...) {
            errors[j] = std::current_exception();
          }
          --running_jobs;
        }
      });
    }
  }
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace tribo::analysis
