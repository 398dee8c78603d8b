// The online calibrator's sliding window of keyframes: which keyframe leaves a full window
// (OnlineSettings::keyframe_selection), and what the last solves measured of each keyframe. Not
// thread-safe: the calibrator guards it with its lock.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

class KeyframeWindow {
 public:
  /// Holds at most max(1, `size`) keyframes. `selection` "information" drops the keyframe whose
  /// loss costs least in the window's weakest direction, anything else the oldest.
  KeyframeWindow(int size, const std::string& selection);

  size_t size() const { return keyframes_.size(); }
  bool empty() const { return keyframes_.empty(); }
  /// Stamps of the keyframes, oldest first.
  std::vector<double> stamps() const;
  /// The keyframes for a solve: shared, or deep copies when the solve modifies them in place
  /// (co-calibration recomputes their stereo clouds; the window's keyframes never change).
  std::vector<std::shared_ptr<Keyframe>> snapshot(bool deep_copies) const;

  /// Appends `keyframe`, then drops keyframes while the window is over-full.
  void add(std::shared_ptr<Keyframe> keyframe);
  /// Removes every keyframe, the set-aside ones and what was measured of them (and oldest-first).
  void clear();
  /// While on, the oldest keyframe leaves a full window whatever the selection (a suspected
  /// change: the monitor needs windows of new keyframes); it is set aside (at most the window's
  /// size of them, by information). Turning it off takes the set-aside keyframes back and selects
  /// again, so a suspicion that clears costs the window nothing.
  void setOldestFirst(bool on);
  /// Removes the keyframes, in the window and set aside, stamped at or before `stamp` (a window
  /// restarted after a change of the extrinsic); returns how many are left in the window.
  size_t dropUpTo(double stamp);
  /// How many keyframes are set aside.
  size_t setAside() const { return set_aside_.size(); }

  /// A solve's per-keyframe LiDAR-stereo information (one per keyframe of `solved`, else
  /// ignored), kept for the keyframes still in the window (it slides during a solve).
  void storeInformation(const std::vector<std::shared_ptr<Keyframe>>& solved,
                        const std::vector<Matrix6d>& information);
  /// Replaces the window's keyframes by those of `solved` whose stereo cloud was recomputed for
  /// another left->right extrinsic (matched by stamp).
  void adoptRecomputedClouds(const std::vector<std::shared_ptr<Keyframe>>& solved);

 private:
  /// Index of the keyframe to drop from over-full `keyframes` (oldest first), by the selection.
  size_t keyframeToDrop(const std::deque<std::shared_ptr<Keyframe>>& keyframes) const;
  /// Drops from `keyframes` (the window's or the set-aside ones), by the selection, while they
  /// are more than the window's size; what leaves is forgotten.
  void trim(std::deque<std::shared_ptr<Keyframe>>* keyframes);

  int size_;
  bool by_information_;
  bool oldest_first_ = false;
  std::deque<std::shared_ptr<Keyframe>> keyframes_;
  /// Keyframes that left the window while oldest-first, oldest first.
  std::deque<std::shared_ptr<Keyframe>> set_aside_;
  /// Per-keyframe LiDAR-stereo information from the last solve that used it, by stamp (of the
  /// window's and the set-aside keyframes).
  std::map<double, Matrix6d> information_;
};

}  // namespace tescalib
