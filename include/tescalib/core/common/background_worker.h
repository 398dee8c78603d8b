// A thread that runs a job on the items handed to it, at a lower scheduling priority than the
// threads that hand them over: work that a later consumer would otherwise do itself (it is an
// advance, never a necessity), done on the cores a real-time pipeline leaves idle. At most
// `capacity` items wait; when a new one comes, the oldest waiting one is dropped.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace tescalib {

/// Lowers the calling thread's scheduling priority by `nice` steps (Linux: the thread's nice
/// value; the threads it starts inherit it). False where that is not possible.
bool lowerThisThreadsPriority(int nice);

template <typename T>
class BackgroundWorker {
 public:
  /// `job` runs on the worker thread, one item at a time; an exception it throws is counted in
  /// failed() and its message kept in lastError(), and the worker goes on.
  BackgroundWorker(std::function<void(T&)> job, size_t capacity, int nice)
      : job_(std::move(job)), capacity_(capacity < 1 ? 1 : capacity), nice_(nice) {
    thread_ = std::thread([this] { loop(); });
  }
  /// Stops after the running job; waiting items are dropped.
  ~BackgroundWorker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  BackgroundWorker(const BackgroundWorker&) = delete;
  BackgroundWorker& operator=(const BackgroundWorker&) = delete;

  void push(T item) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      waiting_.push_back(std::move(item));
      while (waiting_.size() > capacity_) {
        waiting_.pop_front();
        ++dropped_;
      }
    }
    cv_.notify_all();
  }
  /// Waits until no item waits and no job runs.
  void drain() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_cv_.wait(lock, [this] { return waiting_.empty() && !busy_; });
  }
  size_t done() const { return locked(done_); }
  size_t dropped() const { return locked(dropped_); }
  size_t failed() const { return locked(failed_); }
  std::string lastError() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_error_;
  }

 private:
  size_t locked(const size_t& v) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return v;
  }
  void loop() {
    lowerThisThreadsPriority(nice_);
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return stop_ || !waiting_.empty(); });
      if (stop_) return;
      T item = std::move(waiting_.front());
      waiting_.pop_front();
      busy_ = true;
      lock.unlock();
      std::string error;
      try {
        job_(item);
      } catch (const std::exception& e) {
        error = e.what();
      } catch (...) {
        error = "unknown exception";
      }
      lock.lock();
      busy_ = false;
      ++(error.empty() ? done_ : failed_);
      if (!error.empty()) last_error_ = error;
      idle_cv_.notify_all();
    }
  }

  std::function<void(T&)> job_;
  const size_t capacity_;
  const int nice_;
  mutable std::mutex mutex_;
  std::condition_variable cv_, idle_cv_;
  std::deque<T> waiting_;  ///< GUARDED_BY(mutex_)
  bool stop_ = false, busy_ = false;
  size_t done_ = 0, dropped_ = 0, failed_ = 0;
  std::string last_error_;
  std::thread thread_;  ///< last: started once everything above exists
};

}  // namespace tescalib
