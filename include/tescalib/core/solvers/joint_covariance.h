// The joint calibration's uncertainty (solvers/joint_calibration.h): the joint problem's own
// marginals take every residual as independent and are over-confident (mean NEES 33 on 7
// generated windows), so the alternation's NEES-calibrated covariances are evaluated at the joint
// estimate instead, plus the joint model error (JointCalibrationSettings::model_sigma_*).
#pragma once

#include <string>
#include <vector>

#include "tescalib/core/solvers/joint_calibration.h"

namespace tescalib {

/// Brings the window's clouds to the joint estimate (`T_cl`, `T_rl`) and runs one warm left-right
/// solve and one LiDAR-stereo fine solve (scale and yaw free, split-window check) from it; their
/// covariances, flags, photo-consistency and messages go into `res->lidar` and `res->stereo` (not
/// their estimates; `res->lidar.fine_inliers` stays the joint problem's), combined as coCalibrate
/// combines them, with the joint model error added. Adds their times to `res`. Returns why the
/// joint estimate is not trusted ("" when it is): a covariance solve that did not converge at it,
/// or the second opinion's doubt (asked when the LiDAR estimate moved far from `T_cam_lidar_init`).
std::string covarianceAtJointEstimate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                      const Eigen::Isometry3d& T_cl, const Eigen::Isometry3d& T_rl,
                                      const Eigen::Isometry3d& T_cam_lidar_init,
                                      const JointCalibrationSettings& js, bool debug,
                                      CoCalibrationResult* res);

}  // namespace tescalib
