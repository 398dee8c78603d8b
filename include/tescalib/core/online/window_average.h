// The published estimate while an extrinsic is unchanged: the information-weighted mean of the
// last few fresh windows that agreed with it (the monitor's counted windows,
// calibration_monitor.h). One window's estimate moves with its scene by about its sigma; the
// mean of windows from different stretches of the drive averages that away and changes by a
// fraction of it per window, so the published extrinsic is steadier and closer to the truth,
// and a window straddling a change of the rig moves it little before the monitor notices.
// Each window weighs with the inverse of its covariance, times the share of its keyframes that
// no earlier counted window held. The covariance stays the newest window's: the windows share
// errors (the scene-independent model error) that averaging does not remove, so the mean claims
// no more precision than one window. ROS-free, not thread-safe (the calibrator guards it).
#pragma once

#include <deque>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/online/online_estimate.h"

namespace tescalib {

/// The information-weighted mean of poses in the project's perturbation model (geometry.h):
/// Gauss-Newton from the last pose. `weights[i]` (6x6, positive semi-definite, their sum
/// invertible) weighs `poses[i]`.
Eigen::Isometry3d weightedMeanPose(const std::vector<Eigen::Isometry3d>& poses,
                                   const std::vector<Matrix6d>& weights);

class WindowAverage {
 public:
  /// `capacity`: the windows averaged at most (the oldest leaves first).
  explicit WindowAverage(int capacity) : capacity_(capacity) {}

  /// Starts again from `e` alone (an estimate published without averaging).
  void restart(const OnlineEstimate& e, double share = 1.0);
  /// Adds the estimate of a fresh window that agreed, `share` of whose keyframes are new, and
  /// returns it with its extrinsics replaced by the mean (covariances, flags and stamps its own).
  /// A covariance that cannot be inverted starts the average again from `e`.
  OnlineEstimate add(const OnlineEstimate& e, double share);
  void clear() { windows_.clear(); }
  size_t size() const { return windows_.size(); }

 private:
  struct Window {
    Eigen::Isometry3d T_cam_lidar, T_right_left;
    Matrix6d weight_lidar, weight_stereo;
    bool stereo_estimated = false;
  };
  /// The window of `e` with weight `share` times its information; false when a covariance it
  /// needs is not invertible.
  static bool windowOf(const OnlineEstimate& e, double share, Window* w);
  int capacity_;
  std::deque<Window> windows_;
};

}  // namespace tescalib
