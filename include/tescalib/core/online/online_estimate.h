// An estimate of the online calibrator: the published one, or a solve's result held back (with
// why, OnlineEstimate::message).
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

/// What the calibrator currently believes.
struct OnlineEstimate {
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  Matrix6d cov_lidar = Matrix6d::Identity();
  Matrix6d cov_stereo = Matrix6d::Identity();
  /// cov_lidar with the left-right pair taken as exact (a LiDAR-first estimate's cov_lidar; a
  /// co-calibrated one's before the pair's uncertainty was propagated into it).
  Matrix6d cov_lidar_given_stereo = Matrix6d::Identity();
  /// false: the solve ended before computing that covariance (a ~candidate whose LiDAR-stereo or
  /// left-right solve stopped early); cov_* then hold placeholders, not uncertainties.
  bool cov_lidar_known = true, cov_stereo_known = true;
  bool observable_lidar[6] = {false, false, false, false, false, false};
  bool observable_stereo[6] = {false, false, false, false, false, false};
  /// The LiDAR-stereo solve's weakest direction (LidarStereoResult::weakest: what the window
  /// constrains, in units of the trust limits).
  WeakDirection weakest_lidar;
  /// The same for T_right_left (the left-right solve's; ratio 0 when it is not estimated).
  WeakDirection weakest_stereo;
  bool converged = false;
  int keyframes_used = 0;
  /// Fresh windows whose estimates it averages (window_average.h; 1: this window's alone).
  int windows_averaged = 1;
  double cost_lidar = 0, cost_stereo = 0;
  int iterations_lidar = 0, iterations_stereo = 0;
  int co_rounds = 0;  ///< co-calibration rounds of the solve (0: LiDAR-stereo only)
  /// T_right_left comes from a co-calibration (false: the initial one, cov_stereo zero).
  bool stereo_estimated = false;
  double stamp = 0;  ///< stamp of the newest keyframe of the window it came from
  double solve_seconds = 0;
  /// Numbers the solves whose result was kept (lastSolve), from 1: a caller publishing every
  /// solve's result tells a new one from the one before (a discarded solve keeps the old).
  uint64_t solve_id = 0;
  /// OnlineCalibrator::lastSolve: why the solve was not published (empty when it was).
  std::string message;
  /// Held only because the published estimate averages fresh windows and this window is not
  /// one (window_average.h): the normal course, not a problem.
  bool held_between_windows = false;
  /// e^T (P + P_published)^-1 e of this T_cam_lidar against the estimate published before the
  /// solve (OnlineSettings::changed_chi2); NaN when there was none or the solve did not converge.
  double chi2_to_published = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace tescalib
