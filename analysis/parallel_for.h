// Independent jobs on the machine's cores: the diagnosis fits each round's
// candidates at once (they share only read-only data). fn(j) must write only
// its own slot j, so the result does not depend on the schedule.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
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

// Chains of tests, each chain tried step by step until a step passes:
// test(c, k) for chain c's steps k in [0, steps[c]). Returns, for each chain,
// the first step that passed (steps[c] when none did): the sequential loop's
// answer whatever the schedule, test being a function of (c, k) alone. On up
// to `threads` threads (0: one per core): a thread takes the next step of a
// chain whose earlier steps have all failed; with none such, the next step of
// a chain still being tested (its answer is used only if the earlier steps
// fail), so that a chain longer than the others does not leave a core idle
// while it runs step after step. The first exception thrown is rethrown.
template <class Test>
std::vector<std::size_t> first_passing_steps(const std::vector<std::size_t>& steps, unsigned threads, Test test) {
  enum class State : char { kWaiting, kRunning, kFailed, kPassed };
  std::vector<std::vector<State>> state;
  std::size_t total = 0;
  for (std::size_t count : steps) {
    state.emplace_back(count, State::kWaiting);
    total += count;
  }
  // The first step of chain c that did not fail (its count when all did),
  // and whether the chain's answer is known.
  const auto first_open = [&](std::size_t c) {
    std::size_t k = 0;
    while (k < state[c].size() && state[c][k] == State::kFailed) ++k;
    return k;
  };
  const auto known = [&](std::size_t c) {
    const std::size_t k = first_open(c);
    return k == state[c].size() || state[c][k] == State::kPassed;
  };
  std::mutex mutex;
  std::exception_ptr error;
  // The next step to run, or false when none is worth running.
  const auto take = [&](std::size_t& chain, std::size_t& step) {
    for (int speculative = 0; speculative < 2; ++speculative) {
      for (std::size_t c = 0; c < state.size(); ++c) {
        if (known(c)) continue;
        std::size_t k = first_open(c);
        if (speculative) {
          bool passed = false;
          while (k < state[c].size() && state[c][k] != State::kWaiting) passed = passed || state[c][k++] == State::kPassed;
          if (passed) continue;
        }
        if (k < state[c].size() && state[c][k] == State::kWaiting) {
          state[c][k] = State::kRunning;
          chain = c;
          step = k;
          return true;
        }
      }
    }
    return false;
  };
  const auto work = [&] {
    std::unique_lock lock(mutex);
    std::size_t c = 0, k = 0;
    while (!error && take(c, k)) {
      lock.unlock();
      bool passed = false;
      std::exception_ptr thrown;
      try {
        passed = test(c, k);
      } catch (...) {
        thrown = std::current_exception();
      }
      lock.lock();
      if (thrown && !error) error = thrown;
      state[c][k] = passed ? State::kPassed : State::kFailed;
    }
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t workers = std::min<std::size_t>(total, threads);
  if (workers <= 1) {
    work();
  } else {
    std::vector<std::jthread> pool;
    for (std::size_t w = 0; w < workers; ++w) pool.emplace_back(work);
  }
  if (error) std::rethrow_exception(error);
  std::vector<std::size_t> out;
  for (std::size_t c = 0; c < state.size(); ++c) out.push_back(first_open(c));
  return out;
}

}  // namespace tribo::analysis
