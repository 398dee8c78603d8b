// BackgroundWorker: every item handed over runs once, in order, on a thread of lower priority;
// beyond its capacity the oldest waiting items are dropped; a job's exception is counted and the
// worker goes on.
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <vector>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <gtest/gtest.h>

#include "tescalib/core/common/background_worker.h"

using namespace tescalib;

TEST(BackgroundWorker, RunsEveryItemInOrder) {
  std::vector<int> seen;
  BackgroundWorker<int> w([&](int& i) { seen.push_back(i); }, 100, 0);
  for (int i = 0; i < 50; ++i) w.push(i);
  w.drain();
  ASSERT_EQ(seen.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(seen[i], i);
  EXPECT_EQ(w.done(), 50u);
  EXPECT_EQ(w.dropped(), 0u);
}

TEST(BackgroundWorker, DropsTheOldestWaitingBeyondItsCapacity) {
  std::mutex m;
  std::condition_variable cv;
  bool release = false, started = false;
  std::vector<int> seen;
  BackgroundWorker<int> w(
      [&](int& i) {
        std::unique_lock<std::mutex> lock(m);
        started = true;
        cv.notify_all();
        cv.wait(lock, [&] { return release; });
        seen.push_back(i);
      },
      2, 0);
  w.push(0);
  {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return started; });  // item 0 runs and holds the worker
  }
  for (int i = 1; i <= 5; ++i) w.push(i);  // 1, 2, 3 dropped; 4 and 5 wait
  {
    std::lock_guard<std::mutex> lock(m);
    release = true;
  }
  cv.notify_all();
  w.drain();
  EXPECT_EQ(seen, (std::vector<int>{0, 4, 5}));
  EXPECT_EQ(w.dropped(), 3u);
  EXPECT_EQ(w.done(), 3u);
}

TEST(BackgroundWorker, AJobsExceptionIsCountedAndTheWorkerGoesOn) {
  std::atomic<int> ran{0};
  BackgroundWorker<int> w(
      [&](int& i) {
        if (i == 1) throw std::runtime_error("no edges in this keyframe");
        ++ran;
      },
      10, 0);
  for (int i = 0; i < 3; ++i) w.push(i);
  w.drain();
  EXPECT_EQ(ran.load(), 2);
  EXPECT_EQ(w.failed(), 1u);
  EXPECT_EQ(w.lastError(), "no edges in this keyframe");
}

#if defined(__linux__)
TEST(BackgroundWorker, RunsAtALowerPriorityThanItsCaller) {
  const auto niceOfThisThread = [] {
    return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  };
  const int caller = niceOfThisThread();
  if (caller > 19 - 5) GTEST_SKIP() << "the test runs at nice " << caller << " already";
  int worker = -100;
  BackgroundWorker<int> w([&](int&) { worker = niceOfThisThread(); }, 1, 5);
  w.push(0);
  w.drain();
  EXPECT_EQ(worker, caller + 5);
  EXPECT_EQ(niceOfThisThread(), caller);  // the caller's own priority is untouched
}
#endif
