// The baseline a user would otherwise pick: PCL's GICP registering each keyframe's LiDAR scan to
// its SGBM stereo cloud from the same initial guess, the per-keyframe results averaged over the
// window (scans of different keyframes cannot be stacked into one cloud without vehicle poses).
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

struct GicpBaselineSettings {
  double voxel = 0.2;               ///< m, both clouds
  double max_correspondence = 1.0;  ///< m
  int max_iterations = 50;
  double max_depth = 40.0;  ///< m, both clouds (like the stereo cloud)
};

struct GicpBaselineResult {
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  bool converged = false;  ///< GICP reported convergence on every keyframe
  double fitness = 0;      ///< mean PCL fitness score
};

GicpBaselineResult solveGicpBaseline(const std::vector<const Keyframe*>& window,
                                     const Eigen::Isometry3d& T_init,
                                     const GicpBaselineSettings& settings = {});

}  // namespace tescalib
