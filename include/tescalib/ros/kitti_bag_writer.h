// Writes a KITTI sequence (odometry or raw layout) to a rosbag with kitti2bag's topic and frame
// names and its camera_info convention (P = the dataset's P2 / P3, fourth columns measured from
// cam0), so launch files and the node's camera_info parsing work the same on bags users already
// have.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "tescalib/core/io/kitti_reader.h"

namespace tescalib {

struct KittiBagOptions {
  std::string velo_topic = "/kitti/velo/pointcloud";
  std::string velo_frame = "velo_link";
  std::string left_prefix = "/kitti/camera_color_left";  ///< + /image_raw, /camera_info
  std::string left_frame = "camera_color_left";
  std::string right_prefix = "/kitti/camera_color_right";
  std::string right_frame = "camera_color_right";
  std::string base_frame = "base_link";
  /// Odometry-layout stamps start at 0 s; ROS times must be positive, so they are shifted to
  /// start here (seconds since the epoch). Raw-layout stamps are absolute and kept as they are.
  double odometry_start_stamp = 1317384000.0;
  /// Nanoseconds added to every stamp: a bag whose stamps are not on the whole-0.1 s grid of the
  /// files (as a real driver's are not), for tests of stamp handling.
  uint32_t stamp_offset_nsec = 0;
  int max_frames = -1;  ///< -1: all frames
  /// Lay the bag out exactly as kitti2bag's raw mode does, for testing a pipeline against the
  /// bags users have: the LiDAR and the cameras hang off an `imu_link` in /tf_static
  /// (base_link -> imu_link -> velo_link, imu_link -> camera_color_left/right, with a fixed
  /// IMU-to-LiDAR transform like KITTI's), images bgr8, clouds x y z i (float32) without a ring
  /// field. Default: velo_link is the root below base_link, images rgb8, clouds with intensity
  /// and ring.
  bool like_kitti2bag = false;
  std::string imu_frame = "imu_link";
};

/// Writes the bag. Throws tescalib::DataError on unreadable input, rosbag::BagException on an
/// unwritable bag. `progress(i, n)` is called after every frame when set.
void writeKittiBag(const KittiSequence& seq, const std::string& bag_path,
                   const KittiBagOptions& options = {},
                   const std::function<void(size_t, size_t)>& progress = {});

/// Writes several sequences of one rig into one bag, one after the other (each odometry-layout
/// sequence starts 1 s after the previous one ended), e.g. the keyframes of one recording day.
void writeKittiBag(const std::vector<const KittiSequence*>& seqs, const std::string& bag_path,
                   const KittiBagOptions& options = {},
                   const std::function<void(size_t, size_t)>& progress = {});

}  // namespace tescalib
