// Seeded, platform-independent random numbers for the simulated instrument.
// One NoiseSource per noise channel, each seeded from (run seed, channel id),
// so adding a channel never shifts another channel's sequence. The generator
// (xoshiro256**) and the Gaussian transform (Marsaglia's polar method) are
// written out here because std::normal_distribution differs between standard
// libraries.
#pragma once

#include <cstdint>

namespace tribo::sim {

// Mixes a run seed and a stream id into an independent 64-bit seed.
std::uint64_t derive_seed(std::uint64_t run_seed, std::uint64_t stream_id);

class NoiseSource {
 public:
  explicit NoiseSource(std::uint64_t seed);

  std::uint64_t next_u64();
  double uniform();   // [0, 1)
  double gaussian();  // mean 0, standard deviation 1

 private:
  std::uint64_t s_[4];
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace tribo::sim
