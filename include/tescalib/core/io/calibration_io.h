// Writing a calibration result (ROS-free, plain text): the files the online node's ~save service
// and tescalib_calibrate write, so that a result of either can be read back the same way.
//   BASE.yaml              both extrinsics (translation, quaternion xyzw), their 6x6 covariances
//                          over [phi; tau], per-axis sigma and trust flags, converged
//   BASE_calib.txt         KITTI odometry style: P2 = [K | 0], P3 = [K | K t_right_left],
//                          Tr = T_cam_lidar (read back by readKittiOdometryCalib /
//                          rigFromOdometryCalib, e.g. as tescalib_calibrate --init)
//   BASE_static_tf.launch  tf2_ros static_transform_publisher nodes for both transforms
#pragma once

#include <string>

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
