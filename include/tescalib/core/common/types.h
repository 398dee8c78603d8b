// Basic data types shared by the whole ROS-free core.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/pinhole.h"

namespace tescalib {

/// One LiDAR return, in the LiDAR frame.
struct LidarPoint {
  float x = 0.f;          ///< metres
  float y = 0.f;          ///< metres
  float z = 0.f;          ///< metres
  float intensity = 0.f;  ///< reflectance as delivered by the sensor (KITTI: 0..1)
  uint16_t ring = 0;      ///< laser index, 0 = lowest beam
  /// When the point was measured, s from its scan's stamp, as a raw driver reports it (a
  /// PointCloud2 time field); NaN when unknown (KITTI files, the generator): de-skewing then
  /// derives it from the azimuth (scan_motion.h).
  float time = std::numeric_limits<float>::quiet_NaN();
};
using LidarScan = std::vector<LidarPoint>;

/// Rectified pinhole intrinsics of one camera.
struct CameraIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;

  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
    return k;
  }
  bool valid() const { return fx > 0 && fy > 0 && width > 0 && height > 0; }

  /// The pixel (u, v) of a camera-frame point (projectPinhole, in double).
  template <typename P>
  Eigen::Vector2d project(const P& p) const {
    return projectPinhole(fx, fy, cx, cy, p);
  }
  /// The ray through pixel (u, v) at depth 1 (pinholeRay).
  Eigen::Vector3d ray(double u, double v) const { return pinholeRay(fx, fy, cx, cy, u, v); }
  /// The camera-frame point at depth z seen in pixel (u, v) (backProjectPinhole).
  Eigen::Vector3d backProject(double u, double v, double z) const {
    return backProjectPinhole(fx, fy, cx, cy, u, v, z);
  }
};

/// The sensor rig: both cameras' rectified intrinsics and the two extrinsics.
/// `T_a_b` maps points from frame b into frame a.
struct StereoRig {
  CameraIntrinsics left;
  CameraIntrinsics right;
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();   ///< LiDAR -> left camera
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();  ///< left -> right camera

  /// Stereo baseline in metres (norm of the left->right translation).
  double baseline() const { return T_right_left.translation().norm(); }
};

/// One synchronized sensor frame.
struct Frame {
  int index = -1;    ///< frame number within its sequence (file name number)
  double stamp = 0;  ///< seconds
  LidarScan scan;    ///< LiDAR points with ring
  cv::Mat left;      ///< left image, CV_8UC3 BGR
  cv::Mat right;     ///< right image, CV_8UC3 BGR
};

}  // namespace tescalib
