// Photometric consistency checks between a LiDAR scan and a rectified stereo pair: do the LiDAR
// depths predict the disparity at which the left and right images agree best? Used by tests and
// by the tools to sanity-check data and ground truth.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/types.h"

namespace tescalib {

struct DisparityAgreement {
  int points = 0;                  ///< LiDAR points that were tested (textured, inside both images)
  double median_shift = 0;         ///< median over points of the best extra shift (px)
  double fraction_within_1px = 0;  ///< fraction of points whose best extra shift is within 1 px
  int best_global_shift = 0;       ///< arg-min of the summed SAD over all points
};

/// For every LiDAR point projected into the left image with `T_cam_lidar`, the predicted
/// disparity is fx * baseline / Z. The right image is searched at that disparity plus an extra
/// shift in [-max_shift, max_shift] (5x5 SAD on grey values); returns where the best shift lies.
/// Only points on textured pixels (gradient above a threshold) are used.
DisparityAgreement lidarDisparityAgreement(const LidarScan& scan, const cv::Mat& left_bgr,
                                           const cv::Mat& right_bgr, const StereoRig& rig,
                                           const Eigen::Isometry3d& T_cam_lidar, int max_shift = 8);

}  // namespace tescalib
