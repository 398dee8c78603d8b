// Sub-pixel refinement of an SGBM disparity map (beyond the paper): SGBM's smoothness term and its
// parabola fit bias slanted surfaces towards fronto-parallel. On generated drives with exact ground
// truth the road comes out 0.16 px (MODE_SGBM_3WAY) to 0.5 px (MODE_SGBM) short in disparity, which
// tilts the stereo road by 0.04-0.12 deg and biases the LiDAR-stereo pitch by the same amount.
// Each iteration re-warps the right image with the current per-pixel disparity, so a slanted
// surface is matched with a slanted window, and solves per window (weighted box sums) for a common
// disparity correction and a local affine brightness between the cameras:
//   I_r(u - d(u, v) - delta, v) = alpha * I_l(u, v) + beta.
// The refined value at the window centre is the window mean of d plus delta: on a plane the mean of
// an affine disparity is its centre value, so this also averages out SGBM's per-pixel noise.
#pragma once

#include <opencv2/core.hpp>

namespace tescalib {

struct DisparityRefinementSettings {
  int iterations = 2;               ///< warp + solve rounds (0 disables the refinement)
  int window_radius = 4;            ///< px; the window is (2r+1)^2
  double max_step = 1.0;            ///< px; larger corrections of one round are clamped
  double min_gradient = 0.5;        ///< grey levels/px, RMS over the window; below it d is kept
  double min_valid_fraction = 0.6;  ///< of the window's pixels with a disparity
  /// The first this many rounds take the x gradient of the right image smoothed by a Gaussian
  /// (sigma `smoothed_gradient_sigma` px), the later ones the exact gradient. Under image noise
  /// one round with the exact gradient corrects SGBM's short disparity on the near road only
  /// partly (the Gauss-Newton step falls short where the texture is fine and weak); a smoothed
  /// first round gets most of the way and an exact second one keeps the precision (the default:
  /// 2 rounds, the first smoothed).
  int smoothed_gradient_rounds = 1;
  double smoothed_gradient_sigma = 1.0;  ///< px; <= 0: every round takes the exact gradient
};

/// Refines `disparity` (CV_32F, px, NaN where invalid) in place for the rectified grey pair
/// (CV_8U or CV_32F, same size). Invalid pixels stay invalid.
void refineDisparity(const cv::Mat& left_gray, const cv::Mat& right_gray, cv::Mat* disparity,
                     const DisparityRefinementSettings& settings = {});

}  // namespace tescalib
