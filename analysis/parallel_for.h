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
        for (std::size_t j = next++; j < count; j = next++) {
          try {
            fn(j);
          } catch (...) {
            errors[j] = std::current_exception();
          }
        }
      });
    }
  }
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace tribo::analysis
