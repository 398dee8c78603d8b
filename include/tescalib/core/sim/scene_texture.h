// Procedural texture building blocks of the scene generator: value noise whose octaves fade out
// below the pixel footprint, and box-filtered patterns (pulse trains, bands). Filtering by the
// footprint is the texture anti-aliasing: a brick joint or a lane marking covers a pixel by the
// fraction it really covers, so both cameras see the same band-limited signal.
// Inline: these are evaluated several times per pixel.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {

inline float clamp01(float x) { return std::min(std::max(x, 0.f), 1.f); }
inline float mixf(float a, float b, float t) { return a + (b - a) * t; }
inline float smooth01(float t) { return t * t * (3.f - 2.f * t); }

/// Lattice value in [-1, 1].
inline float latticeValue(int32_t ix, int32_t iy, uint32_t seed) {
  return unitFloat(hash32(static_cast<uint32_t>(ix) + seed, static_cast<uint32_t>(iy))) * 2.f - 1.f;
}
inline float latticeValue(int32_t ix, int32_t iy, int32_t iz, uint32_t seed) {
  return unitFloat(hash32(static_cast<uint32_t>(ix) + seed, static_cast<uint32_t>(iy),
                          static_cast<uint32_t>(iz))) *
             2.f -
         1.f;
}

/// Smooth 2D value noise in [-1, 1] with unit lattice spacing.
inline float valueNoise(float x, float y, uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy);
  const float tx = smooth01(x - fx), ty = smooth01(y - fy);
  const float a = latticeValue(ix, iy, seed), b = latticeValue(ix + 1, iy, seed);
  const float c = latticeValue(ix, iy + 1, seed), d = latticeValue(ix + 1, iy + 1, seed);
  return mixf(mixf(a, b, tx), mixf(c, d, tx), ty);
}

/// Smooth 3D value noise in [-1, 1] with unit lattice spacing.
inline float valueNoise(float x, float y, float z, uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy),
                iz = static_cast<int32_t>(fz);
  const float tx = smooth01(x - fx), ty = smooth01(y - fy), tz = smooth01(z - fz);
  float layer[2];
  for (int k = 0; k < 2; ++k) {
    const float a = latticeValue(ix, iy, iz + k, seed), b = latticeValue(ix + 1, iy, iz + k, seed);
    const float c = latticeValue(ix, iy + 1, iz + k, seed);
    const float d = latticeValue(ix + 1, iy + 1, iz + k, seed);
    layer[k] = mixf(mixf(a, b, tx), mixf(c, d, tx), ty);
  }
  return mixf(layer[0], layer[1], tz);
}

/// Weight of a detail of size `wavelength` seen through a pixel of size `footprint` (same
/// units): 1 when it spans two pixels or more, fading to 0 at one pixel.
inline float lodWeight(float wavelength, float footprint) {
  return clamp01(wavelength / footprint - 1.f);
}

/// Sum of `octaves` octaves of 2D value noise, the first with `wavelength`, each next one with
/// half the wavelength and `gain` times the amplitude. Octaves finer than the footprint fade out.
inline float fractalNoise(float x, float y, float wavelength, int octaves, float gain,
                          float footprint, uint32_t seed) {
  float sum = 0.f, amp = 1.f;
  for (int o = 0; o < octaves; ++o) {
    const float w = lodWeight(wavelength, footprint);
    if (w <= 0.f) break;
    sum += amp * w * valueNoise(x / wavelength, y / wavelength, seed + 0x9e37u * o);
    wavelength *= 0.5f;
    amp *= gain;
  }
  return sum;
}

/// 3D version of fractalNoise().
inline float fractalNoise(float x, float y, float z, float wavelength, int octaves, float gain,
                          float footprint, uint32_t seed) {
  float sum = 0.f, amp = 1.f;
  for (int o = 0; o < octaves; ++o) {
    const float w = lodWeight(wavelength, footprint);
    if (w <= 0.f) break;
    const float s = 1.f / wavelength;
    sum += amp * w * valueNoise(x * s, y * s, z * s, seed + 0x9e37u * o);
    wavelength *= 0.5f;
    amp *= gain;
  }
  return sum;
}

/// Integral from 0 to x of the pulse train that is 1 on [k period, k period + on).
inline float pulseIntegral(float x, float period, float on) {
  const float k = std::floor(x / period);
  return k * on + std::min(x - k * period, on);
}

/// The pulse train box-filtered over [x - footprint/2, x + footprint/2]: the fraction of the
/// pixel covered by the "on" part.
inline float boxPulse(float x, float period, float on, float footprint) {
  if (footprint < 1e-4f * period) {
    const float r = x - std::floor(x / period) * period;
    return r < on ? 1.f : 0.f;
  }
  if (footprint > 8.f * period) return on / period;
  return clamp01((pulseIntegral(x + 0.5f * footprint, period, on) -
                  pulseIntegral(x - 0.5f * footprint, period, on)) /
                 footprint);
}

/// Fraction of [x - footprint/2, x + footprint/2] inside [a, b].
inline float boxBand(float x, float a, float b, float footprint) {
  const float f = std::max(footprint, 1e-5f);
  const float lo = std::max(x - 0.5f * f, a), hi = std::min(x + 0.5f * f, b);
  return std::max(hi - lo, 0.f) / f;
}

/// Random value in [0, 1) for an integer cell (a brick, a tile, a window) of an object.
inline float cellRandom(int32_t i, int32_t j, uint32_t seed) {
  return unitFloat(hash32(static_cast<uint32_t>(i) + seed, static_cast<uint32_t>(j) ^ 0x5bd1e995u));
}

}  // namespace sim
}  // namespace tescalib
