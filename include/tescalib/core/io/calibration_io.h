// Writing and reading a calibration result (ROS-free): the files the online node's ~save service
// and tescalib_calibrate write, so that a result of either can be read back the same way.
//   BASE.yaml              both extrinsics (translation, quaternion xyzw), their 6x6 covariances
//                          over [phi; tau], per-axis sigma and trust flags, converged
//   BASE_calib.txt         KITTI odometry style: P2 = [K | 0], P3 = [K | K t_right_left],
//                          Tr = T_cam_lidar (read back by readKittiOdometryCalib /
//                          rigFromOdometryCalib, e.g. as tescalib_calibrate --init)
//   BASE_static_tf.launch  tf2_ros static_transform_publisher nodes for both transforms
#pragma once

#include <string>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/online/online_calibrator.h"

namespace tescalib {

/// Frame names written into the YAML and the launch file.
struct CalibrationFrames {
  std::string lidar = "velo_link";
  std::string left = "tescalib_left";
  std::string right = "tescalib_right";
};

std::string calibrationYaml(const OnlineEstimate& e, const CalibrationFrames& frames);
std::string staticTransformLaunch(const OnlineEstimate& e, const CalibrationFrames& frames);
/// The rig's intrinsics with the estimate's extrinsics (see the file comment).
KittiOdometryCalib calibrationAsKitti(const StereoRig& rig, const OnlineEstimate& e);

/// A result file (BASE.yaml) read back: both extrinsics, their covariances over [phi; tau] and
/// frames. A covariance the file gives as null (unknown) is left at zero with its flag false.
struct CalibrationFile {
  CalibrationFrames frames;
  bool converged = false;
  double stamp = 0;
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  Matrix6d cov_lidar = Matrix6d::Zero(), cov_stereo = Matrix6d::Zero();
  bool cov_lidar_known = false, cov_stereo_known = false;
  bool stereo_estimated = false;
};

/// Reads a BASE.yaml that calibrationYaml wrote. Throws DataError naming the file and the entry
/// that is missing or invalid (a rotation that is not a unit quaternion, a covariance not 36
/// numbers).
CalibrationFile readCalibrationYaml(const std::string& path);

/// What is wrong with BASE as the files' common name ("" when nothing): empty, or a folder (a
/// trailing '/'). writeCalibrationFiles refuses such a BASE with this message.
std::string calibrationBaseProblem(const std::string& base);

/// Writes the three files BASE.yaml, BASE_calib.txt and BASE_static_tf.launch, as a set: each to
/// a temporary file beside it first, renamed only when all three were written. A trailing
/// ".yaml" of `base` is dropped (result.yaml: BASE result). `message`: the files written, or what
/// went wrong (a folder that does not exist, or the system's reason).
bool writeCalibrationFiles(const std::string& base, const StereoRig& rig, const OnlineEstimate& e,
                           const CalibrationFrames& frames, std::string* message);

}  // namespace tescalib
