#include "sim/noise_source.h"

#include <cmath>

namespace tribo::sim {

namespace {

std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

std::uint64_t derive_seed(std::uint64_t run_seed, std::uint64_t stream_id) {
  std::uint64_t x = run_seed ^ (stream_id * 0xd1b54a32d192ed03ULL);
  splitmix64(x);
  return splitmix64(x);
}

NoiseSource::NoiseSource(std::uint64_t seed) {
  for (auto& word : s_) word = splitmix64(seed);
}

std::uint64_t NoiseSource::next_u64() {
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double NoiseSource::uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

double NoiseSource::gaussian() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  // Polar method: a uniform point in the unit disc gives two independent
  // normals with one log and one sqrt (no trigonometry).
  double u, v, r2;
  do {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    r2 = u * u + v * v;
  } while (r2 >= 1.0 || r2 == 0.0);
  const double scale = std::sqrt(-2.0 * std::log(r2) / r2);
  spare_ = v * scale;
  has_spare_ = true;
  return u * scale;
}

}  // namespace tribo::sim
