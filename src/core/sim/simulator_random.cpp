#include "tescalib/core/sim/simulator_random.h"

#include <array>

namespace tescalib {
namespace sim {
namespace {

constexpr int kTableBits = 16;

/// 65536 standard normal samples drawn once from a fixed seed.
const std::array<float, 1u << kTableBits>& gaussianTable() {
  static const auto table = [] {
    std::array<float, 1u << kTableBits> t{};
    SimRandom rng(0x7e5ca11bULL);
    for (auto& v : t) v = static_cast<float>(rng.normal());
    return t;
  }();
  return table;
}

}  // namespace

float gaussianFromHash(uint32_t h) { return gaussianTable()[h >> (32 - kTableBits)]; }

}  // namespace sim
}  // namespace tescalib
