// Wall-clock seconds for the solvers' per-stage timings.
#pragma once

#include <chrono>

namespace tescalib {

/// Seconds of steady-clock time since `t0`.
inline double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace tescalib
