// Photometric consistency of a calibration: a LiDAR point seen by both cameras has one brightness
// in both images, up to the cameras' affine brightness difference. Projected with the calibration
// (T_cam_lidar into the left image, T_right_left * T_cam_lidar into the right one) it lands on the
// same scene point in both only when the calibration and the point's depth agree; no stereo
// matching is involved. It sees the predicted disparity (the depth axis) and points that slip
// across an object's silhouette, not a shift both projections share.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"

namespace tescalib {

struct PhotometricConsistencySettings {
  double blur_sigma_px = 1.0;   ///< Gaussian blur of both grey images
  double truncate_grey = 20.0;  ///< residuals count up to this many grey levels
  double min_depth_m = 2.0, max_depth_m = 40.0;
  int max_points = 40000;  ///< LiDAR points used per frame (an even stride through the scan)
};

struct PhotometricConsistency {
  int points = 0;       ///< points seen by both cameras
  double gain = 1;      ///< right = gain * left + offset, fitted on the points
  double offset = 0;    ///< grey levels
  double residual = 0;  ///< mean truncated |right - (gain * left + offset)|, grey levels
};

/// The blurred grey image (CV_64F) the consistency samples.
cv::Mat photometricImage(const cv::Mat& bgr, const PhotometricConsistencySettings& s = {});

/// Samples both images (`left`, `right`: photometricImage of the pair) at every used point's
/// projections, fits the affine brightness (least squares, then again on the points within
/// `truncate_grey`) and returns the mean truncated residual. residual 0 and points 0 when fewer
/// than 10 points are seen by both.
PhotometricConsistency photometricConsistency(const LidarScan& scan, const cv::Mat& left,
                                              const cv::Mat& right, const StereoRig& rig,
                                              const Eigen::Isometry3d& T_cam_lidar,
                                              const Eigen::Isometry3d& T_right_left,
                                              const PhotometricConsistencySettings& s = {});

}  // namespace tescalib
