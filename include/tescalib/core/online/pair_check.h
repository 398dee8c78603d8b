// The left-right pair checked on the newest keyframes alone: a photometric solve of T_right_left
// on them, from the published pair, with the key points' depth from the published LiDAR
// extrinsic. The calibration monitor's fresh window for left_to_right under co-calibration: the
// window keeps keyframes by their LiDAR information, so after the pair changes its solves can
// hold mostly keyframes from before the change, and their left-right estimate does not show it;
// the photometric solve reads only the images and the LiDAR, not the stereo clouds rectified for
// the old pair.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/online/online_estimate.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

/// A converged pair check.
struct PairCheck {
  std::vector<double> stamps;  ///< its keyframes' stamps
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  /// With the published LiDAR extrinsic's uncertainty and the left-right model error, as a
  /// co-calibration's (coStereoCovariance), and a LiDAR change of MonitorSettings::
  /// pair_check_lidar_change_*; the baseline length stays the published one.
  Matrix6d covariance = Matrix6d::Zero();
  double seconds = 0;
};

/// Solves the pair on `keyframes` (the newest ones) from `published`; nullopt when the solve does
/// not converge with a known covariance or throws (too little texture, a change beyond its basin,
/// data it cannot use: then the window's own solves are the evidence).
std::optional<PairCheck> checkStereoPair(
    const std::vector<std::shared_ptr<const Keyframe>>& keyframes, const StereoRig& rig,
    const OnlineEstimate& published, const OnlineSettings& settings);

}  // namespace tescalib
