// Signatures of the sensors' errors in the stereo-minus-LiDAR disparity residual
// (lidar_stereo_agreement.h), to tell a recording's errors apart and to compare generated drives
// with real ones: how the residual varies across the image, from one LiDAR ring to the next and
// with the disparity itself.
#pragma once

#include <array>
#include <vector>

#include "tescalib/core/eval/lidar_stereo_agreement.h"

namespace tescalib {

/// residual = offset + scale * d over the samples within DisparityResidual::kMaxDifferencePx, d the
/// LiDAR-predicted disparity: an offset is what a relative yaw of the cameras or a matching bias
/// gives, a scale what a baseline or focal length error of the pair (or a LiDAR range scale
/// error) gives. Iteratively reweighted least squares with Huber's weights (k = 1.345 robust
/// sigmas of the residuals about the fit).
struct DisparityFit {
  int points = 0;
  double offset_px = 0;
  double scale = 0;     ///< fraction of the disparity (0.01: 1 %)
  double sigma_px = 0;  ///< robust spread of the residuals about the fit (1.4826 MAD)
};

DisparityFit fitDisparityOffsetAndScale(const std::vector<DisparitySample>& samples);

/// The residual's medians by the projection's third of the image (left, middle, right) and by
/// LiDAR ring, over the samples within DisparityResidual::kMaxDifferencePx, and the fit above.
/// A per-ring error of the LiDAR (each laser's own range offset or elevation) shows as jumps
/// between neighbouring rings' medians; a rotation of the right camera about the vertical or a
/// lens's distortion as a change across the image.
struct DisparitySignatures {
  static constexpr int kThirds = 3;
  static constexpr int kMinRingPoints = 30;  ///< a ring with fewer points has no median
  int points = 0;
  std::array<double, kThirds> third_median_px{};  ///< 0 where a third has no points
  std::array<int, kThirds> third_points{};
  std::vector<double> ring_median_px;  ///< by ring number; 0 where a ring has too few points
  std::vector<int> ring_points;        ///< by ring number
  int rings = 0;                       ///< rings with kMinRingPoints points or more
  int ring_pairs = 0;                  ///< neighbouring rings that both have
  /// The median |difference| between neighbouring rings' medians over those pairs, and the
  /// largest one (between rings ring_max_jump_ring and the one above it).
  double ring_jump_px = 0;
  double ring_max_jump_px = 0;
  int ring_max_jump_ring = -1;
  double ring_min_median_px = 0, ring_max_median_px = 0;  ///< over the rings with a median
  DisparityFit fit;
};

DisparitySignatures disparitySignatures(const std::vector<DisparitySample>& samples);

}  // namespace tescalib
