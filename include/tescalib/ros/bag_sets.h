// Reads a rosbag's synchronized sensor sets (point cloud, left and right image, raw or
// compressed, their camera_info) in order, without playing it, and the transforms on /tf_static:
// what tescalib_calibrate --bag calibrates, as fast as the CPU allows instead of at the bag's rate.
#pragma once

#include <functional>
#include <string>

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <Eigen/Geometry>

namespace tescalib {

/// Topic names (kitti2bag's by default, as kitti.launch) and the synchronization tolerance.
struct BagTopics {
  std::string points = "/kitti/velo/pointcloud";
  std::string left = "/kitti/camera_color_left/image_raw";
  std::string right = "/kitti/camera_color_right/image_raw";
  std::string left_info = "/kitti/camera_color_left/camera_info";
  std::string right_info = "/kitti/camera_color_right/camera_info";
  double max_skew = 0.05;  ///< s between the cloud and each image (the node's sync/max_skew)
};

/// One synchronized set: the cloud, the images nearest to its stamp, the latest camera_info of
/// each camera read before them.
struct BagSet {
  sensor_msgs::PointCloud2::ConstPtr cloud;
  sensor_msgs::Image::ConstPtr left, right;
  sensor_msgs::CameraInfo::ConstPtr left_info, right_info;
};

struct BagCounts {
  int clouds = 0, left = 0, right = 0, sets = 0;
  int unmatched_clouds = 0;    ///< no left or right image within max_skew (or no camera_info yet)
  int undecodable_images = 0;  ///< compressed images that do not decode (left out)
};

/// Calls `on_set` for every set, in stamp order of the clouds; each image is matched to the cloud
/// nearest to it within max_skew (the node's approximate sync; kitti2bag's stamps are equal).
/// Throws DataError when the bag cannot be opened or has none of the points topic's messages.
BagCounts readBagSets(const std::string& path, const BagTopics& topics,
                      const std::function<void(const BagSet&)>& on_set);

/// Every transform on /tf_static, for looking up the initial extrinsic. Throws DataError when
/// the bag cannot be opened.
void readBagStaticTf(const std::string& path, tf2::BufferCore* buffer);

/// T_cam_lidar from a bag's /tf_static (readBagStaticTf): the left camera_info's frame (or the
/// left image's) <- the cloud's. Throws DataError "`path`: no LiDAR extrinsic on /tf_static (camera
/// <- cloud: why)`hint`" when tf has no such transform.
Eigen::Isometry3d bagLidarExtrinsic(const std::string& path, const tf2::BufferCore& tf,
                                    const BagSet& set, const std::string& hint = "");

}  // namespace tescalib
