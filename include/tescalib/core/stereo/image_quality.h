// The image-quality gate: exposure and sharpness of each image of a pair, and whether the pair
// is fit for SGBM and the photometric solver.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace tescalib {

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
  /// 30 % or a flare disc 0.86-0.94 on KITTI.
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
