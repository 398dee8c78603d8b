// Co-calibration (paper, "Co-calibration"): alternate the left-right photometric solver and the
// LiDAR-stereo solver, re-rectifying and recomputing the stereo clouds with every new left-right
// estimate, until both estimates are stable.
#pragma once

#include <string>
#include <vector>

#include "tescalib/core/keyframe.h"
#include "tescalib/core/lidar_stereo_solver.h"
#include "tescalib/core/photometric_solver.h"

namespace tescalib {

struct CoCalibrationSettings {
  LidarStereoSettings lidar;
  PhotometricSettings stereo;
  StereoSettings stereo_cloud;
  int max_rounds = 6;
  /// Stable: in one round neither extrinsic moved by more than this.
  double stable_rot_deg = 0.005;
  double stable_trans_m = 0.001;
};

struct CoCalibrationResult {
  LidarStereoResult lidar;   ///< last LiDAR-stereo solve (T_cam_lidar, covariance, ...)
  PhotometricResult stereo;  ///< last left-right solve (T_right_left, covariance, ...)
  int rounds = 0;
  bool stable = false;              ///< the stability criterion was met within max_rounds
  bool converged = false;           ///< stable and both solvers converged
  double seconds_stereo_cloud = 0;  ///< time spent recomputing stereo clouds
  double seconds = 0;
  std::string message;
};

/// Runs the alternation over `window` (stereo clouds are recomputed in place). The stereo solver
/// goes first: it tolerates a bad LiDAR extrinsic (paper, "Sensitivity Analysis").
CoCalibrationResult coCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const Eigen::Isometry3d& T_cam_lidar_init,
                                const Eigen::Isometry3d& T_right_left_init,
                                const CoCalibrationSettings& settings = {});

}  // namespace tescalib
