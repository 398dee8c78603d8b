// Rigs as varied as real ones (tescalib_simulate --rig random): a rectified stereo pair and a
// LiDAR mounting drawn from a seed.
//
// The pair: baseline 0.12-0.6 m, images 640-1400 px wide seeing 60-90 deg across (which gives
// the focal length, 400-1100 px) and 25-50 deg down (up to 600 px), a principal point near the
// image centre, and
// the right camera a few millimetres off the left camera's x axis, vertically and along the
// optical axis, as a real rectified pair's P2/P3 say (KITTI's: 2-3 mm). The pair looks forward,
// tilted and turned by a degree or two, 1.3-1.8 m above the ground.
// The LiDAR: within 1 m of the left camera (above, behind or beside it, at least 1.2 m above the
// ground), its axes turned by a multiple of 90 deg about the vertical (x forward, left, backward
// or right: the conventions drivers use) and then by up to 3 deg about each axis.
#pragma once

#include <cstdint>

#include <Eigen/Geometry>

#include "tescalib/core/io/kitti_reader.h"

namespace tescalib {
namespace sim {

/// Height of the vehicle frame the trajectory moves above the ground (m): where KITTI's HDL-64E
/// sits, and the default rig's LiDAR.
constexpr double kVehicleFrameHeight = 1.73;

/// A generated rig: what calib.txt holds, the image size, and where the LiDAR sits on the
/// vehicle.
struct SimRig {
  KittiOdometryCalib calib;   ///< P0..P3 (one K; cam2 the left, cam3 the right camera) and Tr
  int width = 0, height = 0;  ///< image size (px)
  /// The LiDAR in the vehicle frame the trajectory moves: x forward, y left, z up, its origin
  /// where the default rig's LiDAR sits (1.73 m above the ground).
  Eigen::Isometry3d T_vehicle_lidar = Eigen::Isometry3d::Identity();
};

/// Draws a rig from `seed` (the same seed, the same rig; independent of everything else).
SimRig randomSimRig(uint64_t seed);

}  // namespace sim
}  // namespace tescalib
