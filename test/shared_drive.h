// A generated drive shared by the tests of one binary (a fixture): each frame is rendered once,
// the first time a test asks for it. Rendering is most of a generated test's set-up time, and the
// scene generator is deterministic, so a shared frame is the frame a test would render itself.
#pragma once

#include <map>
#include <mutex>

#include "tescalib/core/sim/simulator.h"

namespace tescalib_test {

class SharedDrive {
 public:
  explicit SharedDrive(const tescalib::SimOptions& options) : sim_(options) {}

  const tescalib::Simulator& sim() const { return sim_; }

  /// Frame i of the drive (thread-safe).
  const tescalib::Frame& frame(int i) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = frames_.find(i);
    if (it == frames_.end()) it = frames_.emplace(i, sim_.renderFrame(i)).first;
    return it->second;
  }

 private:
  tescalib::Simulator sim_;
  mutable std::mutex mutex_;
  mutable std::map<int, tescalib::Frame> frames_;
};

}  // namespace tescalib_test
