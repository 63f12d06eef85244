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

namespace {

// The ziggurat's 128 layers of equal area under exp(-x^2/2): layer i spans
// [0, x[i]], x[1] = R is where the tail begins, x[0] = V / f(R) the base
// layer's width with the tail's area folded in, x[128] = 0.
constexpr int kLayers = 128;
constexpr double kTailStart = 3.442619855899;           // R
constexpr double kLayerArea = 9.91256303526217e-3;      // V

struct Ziggurat {
  double x[kLayers + 1];
  double ratio[kLayers];  // x[i+1] / x[i]
  Ziggurat() {
    const double f = std::exp(-0.5 * kTailStart * kTailStart);
    x[0] = kLayerArea / f;
    x[1] = kTailStart;
    for (int i = 2; i < kLayers; ++i) {
      x[i] = std::sqrt(-2.0 * std::log(kLayerArea / x[i - 1] + std::exp(-0.5 * x[i - 1] * x[i - 1])));
    }
    x[kLayers] = 0.0;
    for (int i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
  }
};

const Ziggurat& ziggurat() {
  static const Ziggurat z;
  return z;
}

}  // namespace

double NoiseSource::tail(bool negative) {
  double a, b;
  do {
    a = -std::log(1.0 - uniform()) / kTailStart;
    b = -std::log(1.0 - uniform());
  } while (b + b < a * a);
  return negative ? -(kTailStart + a) : kTailStart + a;
}

double NoiseSource::gaussian() {
  const Ziggurat& z = ziggurat();
  for (;;) {
    const std::uint64_t bits = next_u64();
    const int layer = static_cast<int>(bits & (kLayers - 1));
    const double u = 2.0 * (static_cast<double>(bits >> 11) * 0x1.0p-53) - 1.0;  // [-1, 1)
    if (std::fabs(u) < z.ratio[layer]) return u * z.x[layer];  // inside the layer's core
    if (layer == 0) return tail(u < 0);
    // The wedge between the layer's core and the curve.
    const double x = u * z.x[layer];
    const double f0 = std::exp(-0.5 * (z.x[layer] * z.x[layer] - x * x));
    const double f1 = std::exp(-0.5 * (z.x[layer + 1] * z.x[layer + 1] - x * x));
    if (f1 + uniform() * (f0 - f1) < 1.0) return x;
  }
}

}  // namespace tribo::sim
