// tescalib_validate --bag: a rosbag's frames (through the node's FrameIntake), its rig from the
// camera_infos and its T_cam_lidar from /tf_static, as tescalib_calibrate --bag reads them.
#pragma once

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "tescalib/core/common/types.h"
#include "tescalib/ros/bag_sets.h"

namespace tescalib::validate {

struct BagRecording {
  StereoRig rig;  ///< intrinsics and baseline from camera_info, T_cam_lidar from /tf_static
  std::vector<Frame> frames;
  std::vector<std::string> labels;  ///< "bag:N", N the synchronized set's number (from 0)
};

/// The frames `spec` names: "keyframes" (sets 0.5 s apart), "all", or the numbers of
/// synchronized sets in `numbers`. Throws DataError when the bag cannot be read, has no
/// usable set or no initial extrinsic on /tf_static.
BagRecording readBagRecording(const std::string& path, const BagTopics& topics,
                              const std::string& spec, const std::set<int>& numbers);

}  // namespace tescalib::validate
