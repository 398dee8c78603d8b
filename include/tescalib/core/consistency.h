// Photometric consistency checks between a LiDAR scan and a rectified stereo pair: do the LiDAR
// depths predict the disparity at which the left and right images agree best? Used by tests and
// by the tools to sanity-check data and ground truth.
#pragma once

#include <array>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/stereo_cloud.h"
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
  static constexpr int kBins = 4;
  static constexpr double kBinEdges[kBins + 1] = {3.0, 7.5, 15.0, 25.0, 40.0};  ///< m
  int points = 0;
  double median_px = 0;                       ///< over all points
  std::array<double, kBins> bin_median_px{};  ///< per depth bin (0 where the bin is empty)
  std::array<int, kBins> bin_points{};
};

DisparityResidual lidarDisparityResidual(const LidarScan& scan, const StereoCloud& cloud,
                                         const Eigen::Isometry3d& T_cam_lidar);

/// Whether the pair's rows agree with its calibration: corners of the left image are followed
/// into the right one (pyramidal Lucas-Kanade, started where the calibration and the stereo
/// cloud's disparity put them) and their vertical offset from that prediction is measured. For a
/// rectified pair the prediction is the same row; a pair whose calibration has a small baseline
/// component along y or z (KITTI's colour cameras: about 3 mm) is predicted with it. SGBM matches
/// along rows, so tenths of a pixel of unexplained vertical offset bias the disparities of
/// oblique texture (road markings, kerbs).
struct VerticalAlignment {
  int points = 0;        ///< corners followed into the right image
  double median_px = 0;  ///< median of v_found - v_predicted
  /// Robust affine fit of that offset, offset + slope_x * x + slope_y * y over the left image's
  /// normalised coordinates x = (u - cx) / fx, y = (v - cy) / fy: the offset is about a relative
  /// pitch of the cameras, slope_x a relative roll, slope_y a difference of vertical focal length.
  double offset_px = 0, slope_x_px = 0, slope_y_px = 0;
  double spread_px = 0;  ///< robust sigma (1.4826 MAD) about the fit
};

/// The vertical alignment of a pair (8-bit BGR or grey, as delivered) under `rig`'s intrinsics and
/// `T_right_left`, with `cloud` the stereo cloud computed from them (its disparity gives each
/// corner's depth). Corners without a disparity are skipped; points = 0 when nothing matched, and
/// with fewer than 10 followed corners the other figures are NaN (not fitted).
VerticalAlignment verticalAlignment(const cv::Mat& left, const cv::Mat& right,
                                    const StereoCloud& cloud, const StereoRig& rig,
                                    const Eigen::Isometry3d& T_right_left, int max_corners = 3000);

/// Exposure and sharpness of one 8-bit image (BGR, BGRA or grey), for telling a pair that SGBM
/// and the photometric solver can use from one with a covered, blinded or defocused camera.
struct ImageQuality {
  double contrast = 0;          ///< standard deviation of the grey values
  double clipped_fraction = 0;  ///< fraction of pixels at <= 2 or >= 253 (black or saturated)
  /// Mean gradient magnitude (Sobel, L1) of the image over that of the image smoothed by a
  /// Gaussian of 2 px: blur lowers it, while brightness, contrast and saturated areas change
  /// both alike. Only comparable between images of one scene: the pair's right/left ratio is
  /// 1.01 on generated drives, 0.92-0.95 on KITTI's frames (its right camera is slightly softer);
  /// a Gaussian blur of the right image by 1 px gives 0.74-0.76 on both, and a saturated top
  /// 30 % or a flare disc 0.86-0.94 on KITTI (session 24).
  double sharpness = 0;
};

/// Throws DataError for an image that is not 8-bit with 1, 3 or 4 channels.
ImageQuality imageQuality(const cv::Mat& image);

struct ImageQualitySettings {
  /// Either image with less contrast is refused: a dark, covered or flat image (generated 32-38,
  /// KITTI 58.8-80.7 grey levels; the generated right image at 15 % brightness: 5.2). 0: no check.
  double min_contrast = 8.0;
  /// Refused when the share of black or saturated pixels of one image exceeds the other's by more
  /// than this: one camera blinded or covered (the sky or the night clips both alike; KITTI's
  /// pairs differ by at most 0.01). 1: no check.
  double max_clipped_difference = 0.4;
  /// Refused when right/left sharpness lies outside [this, 1 / this]: one camera defocused, or
  /// behind a wet or dirty window. In [0, 1); 0: no check.
  double min_sharpness_ratio = 0.75;
};

/// Why the pair should not be used (empty when it can): the first of the checks above that
/// fails, with the measured value and the limit. `left` / `right` (optional) receive the values.
std::string pairQualityProblem(const cv::Mat& left, const cv::Mat& right,
                               const ImageQualitySettings& settings,
                               ImageQuality* left_quality = nullptr,
                               ImageQuality* right_quality = nullptr);

}  // namespace tescalib
