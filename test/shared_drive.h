// A generated drive shared by the tests of one binary (a fixture): each frame is rendered once,
// the first time a test asks for it. Rendering is most of a generated test's set-up time, and the
// scene generator is deterministic, so a shared frame is the frame a test would render itself.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <utility>

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

/// The urban drive of `seed` and `frames` frames (its scene depends on both), one per binary.
inline const SharedDrive& sharedUrbanDrive(uint64_t seed, int frames) {
  static std::mutex mutex;
  static std::map<std::pair<uint64_t, int>, std::unique_ptr<SharedDrive>> drives;
  std::lock_guard<std::mutex> lock(mutex);
  auto& d = drives[{seed, frames}];
  if (!d) {
    tescalib::SimOptions o;
    o.scenario = tescalib::Scenario::kUrban;
    o.frames = frames;
    o.seed = seed;
    d = std::make_unique<SharedDrive>(o);
  }
  return *d;
}

}  // namespace tescalib_test
