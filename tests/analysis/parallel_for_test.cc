// Jobs on the machine's cores (analysis/parallel_for.h): chains of tests
// answer as the sequential loop does, whatever the threads.
#include "analysis/parallel_for.h"

#include <mutex>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace tribo::analysis {
namespace {

// Chain 0 passes at steps 1 and 2, chain 1 never, chain 2 has no step,
// chain 3 passes at its last step only.
bool passes(std::size_t chain, std::size_t step) {
  return (chain == 0 && step >= 1) || (chain == 3 && step == 3);
}

TEST(ParallelFor, ChainsAnswerTheirFirstPassingStepWhateverTheThreads) {
  const std::vector<std::size_t> steps{3, 2, 0, 4};
  for (unsigned threads : {1u, 2u, 4u}) {
    std::mutex mutex;
    std::set<std::pair<std::size_t, std::size_t>> ran;
    const auto first = first_passing_steps(steps, threads, [&](std::size_t c, std::size_t k) {
      {
        std::lock_guard lock(mutex);
        EXPECT_TRUE(ran.emplace(c, k).second) << "step run twice: " << c << ", " << k;
      }
      return passes(c, k);
    });
    EXPECT_EQ(first, (std::vector<std::size_t>{1, 2, 0, 3})) << threads << " threads";
    // Every step before each answer was run; alone, no step after it.
    for (std::size_t k = 0; k <= 1; ++k) EXPECT_TRUE(ran.count({0, k}));
    for (std::size_t k = 0; k < 2; ++k) EXPECT_TRUE(ran.count({1, k}));
    for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(ran.count({3, k}));
    if (threads == 1) {
      EXPECT_FALSE(ran.count({0, 2}));
    }
  }
}

TEST(ParallelFor, AChainsExceptionIsRethrown) {
  EXPECT_THROW(first_passing_steps({2, 2}, 2,
                                   [](std::size_t c, std::size_t k) -> bool {
                                     if (c == 1 && k == 1) throw std::runtime_error("failed");
                                     return false;
                                   }),
               std::runtime_error);
}

}  // namespace
}  // namespace tribo::analysis
