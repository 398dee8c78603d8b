// Whether a LiDAR scan and a rectified stereo pair agree under a calibration: do the LiDAR depths
// predict the disparity at which the left and right images match best, and the disparity SGBM
// found? Used by tests and by the tools to sanity-check data and ground truth.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/stereo/stereo_cloud.h"

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
/// Only points on textured pixels (gradient above a threshold) whose every searched patch lies in
/// the image are used. Throws DataError unless both images are 8-bit and of one size.
DisparityAgreement lidarDisparityAgreement(const LidarScan& scan, const cv::Mat& left_bgr,
                                           const cv::Mat& right_bgr, const StereoRig& rig,
                                           const Eigen::Isometry3d& T_cam_lidar, int max_shift = 8);

/// The stereo cloud's (SGBM, refined) disparity against the one the LiDAR predicts with
/// `T_cam_lidar`, at every LiDAR point 3-40 m in front of the camera with a disparity, in the
/// cloud's rectification: stereo minus LiDAR, differences beyond 3 px (occlusions, mismatches) left
/// out. A calibration both sensors agree with gives about 0 at every depth; a depth-independent
/// offset is what a relative yaw of the cameras or a matching bias gives, and moves the
/// optical-axis estimate by about Z^2 / (f b) per px at depth Z.
struct DisparityResidual {
  static constexpr double kMaxDifferencePx = 3.0;  ///< beyond it: an occlusion or a mismatch
  static constexpr int kBins = 4;
  static constexpr double kBinEdges[kBins + 1] = {3.0, 7.5, 15.0, 25.0, 40.0};  ///< m
  int points = 0;
  double median_px = 0;                       ///< over all points
  std::array<double, kBins> bin_median_px{};  ///< per depth bin (0 where the bin is empty)
  std::array<int, kBins> bin_points{};
  /// Over every point 3-40 m with a stereo disparity, the differences beyond 3 px included as
  /// 3 px: the mean truncated |stereo - LiDAR| (a score of the calibration, lower is better).
  int points_with_disparity = 0;
  double mean_truncated_abs_px = 0;
};

/// One LiDAR point of the residual: 3-40 m in front of the camera, with a stereo disparity at its
/// projection into the cloud's rectified left image.
struct DisparitySample {
  double depth_m = 0;          ///< in the rectified left camera frame
  double lidar_px = 0;         ///< the LiDAR-predicted disparity fx b / Z
  double difference_px = 0;    ///< stereo minus LiDAR-predicted disparity
  double column_fraction = 0;  ///< the projection's column over the image's width (0 to 1)
  int ring = 0;                ///< the LiDAR point's ring
};

/// Every LiDAR point 3-40 m in front of the camera with a stereo disparity, the differences beyond
/// DisparityResidual::kMaxDifferencePx included (the frames of a sequence can be pooled).
std::vector<DisparitySample> disparitySamples(const LidarScan& scan, const StereoCloud& cloud,
                                              const Eigen::Isometry3d& T_cam_lidar);

/// The residual's medians and its truncated mean over `samples` (of one frame or pooled).
DisparityResidual disparityResidualOf(const std::vector<DisparitySample>& samples);

DisparityResidual lidarDisparityResidual(const LidarScan& scan, const StereoCloud& cloud,
                                         const Eigen::Isometry3d& T_cam_lidar);

}  // namespace tescalib
