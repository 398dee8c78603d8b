// Deterministic random numbers for the scene generator. The std:: distributions are
// implementation-defined, so the generator draws every number from these helpers: the same seed
// gives the same scene and the same bytes with any standard library and any thread count.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace tescalib {
namespace sim {

/// SplitMix64 finaliser: a well-mixed 64-bit hash of x.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Seed of a sub-stream: the same (seed, key) always gives the same value.
inline uint64_t subSeed(uint64_t seed, uint64_t key) { return mix64(seed ^ mix64(key + 1)); }

/// 32-bit integer hash (lowbias32) for per-pixel and per-lattice-point values.
inline uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}
inline uint32_t hash32(uint32_t a, uint32_t b) { return hash32(a ^ hash32(b + 0x9e3779b9U)); }
inline uint32_t hash32(uint32_t a, uint32_t b, uint32_t c) { return hash32(a, hash32(b, c)); }

/// Uniform value in [0, 1) from a 32-bit hash.
inline float unitFloat(uint32_t h) { return static_cast<float>(h >> 8) * (1.0f / 16777216.0f); }

/// Standard normal value from a 32-bit hash (table lookup: no log/cos per pixel).
float gaussianFromHash(uint32_t h);

/// A seeded stream of uniform and normal numbers with exactly specified distributions.
class SimRandom {
 public:
  explicit SimRandom(uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [lo, hi].
  int uniformInt(int lo, int hi) {
    return lo + static_cast<int>(uniform() * static_cast<double>(hi - lo + 1));
  }
  /// True with probability p.
  bool chance(double p) { return uniform() < p; }
  /// Standard normal (Box-Muller, one value per call).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// A 32-bit value, e.g. a per-object texture seed.
  uint32_t bits() { return static_cast<uint32_t>(engine_() >> 32); }

 private:
  std::mt19937_64 engine_;
};

}  // namespace sim
}  // namespace tescalib
