// parallelFor: every index exactly once on any number of threads, and a worker's exception
// reaches the caller instead of terminating the process.
#include <atomic>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/parallel.h"

using namespace tescalib;

TEST(Parallel, EveryIndexExactlyOnce) {
  for (int threads : {1, 2, 3, 8}) {
    std::vector<std::atomic<int>> hits(1000);
    parallelFor(1000, threads, [&](int i) { ++hits[i]; });
    for (int i = 0; i < 1000; ++i) ASSERT_EQ(hits[i].load(), 1) << "index " << i << ", " << threads;
  }
  int calls = 0;
  parallelFor(0, 4, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(Parallel, RangesCoverTheLoopWithoutOverlap) {
  for (int blocks : {1, 7, 64, 5000}) {
    std::vector<std::atomic<int>> hits(1003);
    parallelForRanges(1003, 2, blocks, [&](int begin, int end) {
      EXPECT_LE(begin, end);
      for (int i = begin; i < end; ++i) ++hits[i];
    });
    for (int i = 0; i < 1003; ++i) ASSERT_EQ(hits[i].load(), 1) << "index " << i << ", " << blocks;
  }
}

TEST(Parallel, AWorkersExceptionReachesTheCaller) {
  std::atomic<int> done{0};
  EXPECT_THROW(parallelFor(1000000, 2,
                           [&](int i) {
                             if (i == 3) throw std::runtime_error("bad keyframe");
                             ++done;
                           }),
               std::runtime_error);
  EXPECT_LT(done.load(), 999999);  // the hand-out stopped
  EXPECT_THROW(parallelFor(5, 1,
                           [](int i) {
                             if (i == 4) throw std::out_of_range("x");
                           }),
               std::out_of_range);
}
