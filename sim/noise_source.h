// Seeded random numbers for the simulated instrument. One NoiseSource per
// noise channel, each seeded from (run seed, channel id), so adding a channel
// never shifts another channel's sequence. The generator (xoshiro256**) and
// the Gaussian transform (a 128-layer ziggurat, Marsaglia and Tsang 2000, in
// Doornik's double-precision form) are written out here because
// std::normal_distribution differs between standard libraries; the ziggurat
// needs about one 64-bit draw and no transcendental function per normal in
// 99 % of the draws, which matters at six normals per 10 kHz tick.
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
  double tail(bool negative);

  std::uint64_t s_[4];
};

}  // namespace tribo::sim
