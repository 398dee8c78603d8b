// Runs fn(i) for i in [0, n) on `threads` threads, indices handed out one by one. Results are
// deterministic as long as fn(i) only writes its own outputs. The first exception thrown by fn
// stops the hand-out and is rethrown to the caller once every thread has finished.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace tescalib {

/// Threads to use when the caller asks for `requested` (0 = all cores).
inline int resolveThreads(int requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

template <typename Fn>
void parallelFor(int n, int threads, Fn&& fn) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    for (int i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&]() {
    for (int i = next++; i < n; i = next++) {
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = n;  // hand out nothing more
      }
    }
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

/// parallelFor over [0, n) in `blocks` contiguous ranges: fn(begin, end) per range, for loops
/// whose iterations are too cheap to hand out one by one.
template <typename Fn>
void parallelForRanges(int n, int threads, int blocks, Fn&& fn) {
  blocks = std::max(1, std::min(blocks, n));
  parallelFor(blocks, threads, [&](int b) {
    const int begin = static_cast<int>(static_cast<long long>(n) * b / blocks);
    const int end = static_cast<int>(static_cast<long long>(n) * (b + 1) / blocks);
    fn(begin, end);
  });
}

}  // namespace tescalib
