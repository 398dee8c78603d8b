// Runs fn(i) for i in [0, n) on `threads` threads, indices handed out one by one. Results are
// deterministic as long as fn(i) only writes its own outputs.
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace tescalib {
namespace sim {

template <typename Fn>
void parallelFor(int n, int threads, Fn&& fn) {
  threads = std::max(1, std::min(threads, n));
  std::atomic<int> next{0};
  auto worker = [&]() {
    for (int i = next++; i < n; i = next++) fn(i);
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
}

/// Threads to use when the caller asks for `requested` (0 = all cores).
inline int resolveThreads(int requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace sim
}  // namespace tescalib
