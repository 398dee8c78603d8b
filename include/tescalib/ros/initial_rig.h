// The rig the calibration node starts from, assembled from its first synchronized set: the
// camera_infos, the parameters and tf. Kept out of the nodelet so that every way it can fail is
// unit-tested without a ROS master.
#pragma once

#include <string>
#include <vector>

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>

#include "tescalib/core/common/types.h"
#include "tescalib/ros/params.h"

namespace tescalib {

struct InitialRig {
  StereoRig rig;            ///< intrinsics, T_cam_lidar and T_right_left to start from
  std::string lidar_frame;  ///< lidar_frame, or the cloud's frame_id (without a leading '/')
  /// Things the user should know that do not stop the node (lens distortion in camera_info,
  /// camera_info R is not identity, the guess is deliberately perturbed).
  std::vector<std::string> warnings;
};

/// [x y z qx qy qz qw] -> transform (the quaternion normalised).
Eigen::Isometry3d fromVector7(const std::vector<double>& v);

/// Intrinsics and baseline from the camera_infos (initial/T_right_left overrides the baseline);
/// T_cam_lidar from initial/T_cam_lidar, or else tf's lidar_frame -> camera frame (the
/// initial/tf_camera_frame parameter, or the left camera_info's frame_id), looked up with
/// `tf_timeout` s of waiting; then the deliberate perturbation of initial/perturb_*. False with a
/// message saying what to set when the camera_infos are unusable or no initial extrinsic exists.
bool initialRig(const NodeParams& params, const sensor_msgs::PointCloud2& cloud,
                const sensor_msgs::CameraInfo& left_info, const sensor_msgs::CameraInfo& right_info,
                const tf2_ros::Buffer& tf, double tf_timeout, InitialRig* out, std::string* error);

}  // namespace tescalib
