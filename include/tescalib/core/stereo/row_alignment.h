// The row alignment of a stereo pair under its calibration: SGBM matches along rows, so a pair
// whose rows disagree with the calibration biases the disparities of oblique texture.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

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

/// The left->right extrinsic that explains a measured misalignment of the rows: `T_right_left`
/// with the right camera turned about its x axis by -offset_px / fy (a relative pitch: every row
/// offset alike) and about its optical axis by slope_x_px / fy (a relative roll: the offset growing
/// across the image), `fy` the right camera's. A pair rectified with it has rows that agree
/// (computeStereoCloud re-rectifies for a rotated right camera). slope_y_px, a difference of
/// vertical focal length, is not a rotation and stays. `T_right_left` itself when the fit is
/// missing (NaN).
Eigen::Isometry3d rowAlignedExtrinsic(const Eigen::Isometry3d& T_right_left,
                                      const VerticalAlignment& rows, double fy);

/// How far rowAlignedExtrinsic() moves the row farthest from the image's centre (px): |offset| +
/// |slope_x| times the largest normalised x of the (left) image. NaN when the fit is missing.
double largestRowCorrectionPx(const VerticalAlignment& rows, const CameraIntrinsics& left);

}  // namespace tescalib
