// A depth-free estimate of the stereo pair's rotation and baseline direction from left-right
// feature matches (an addition to the paper). The photometric left-right solve needs key point
// depth from the LiDAR; with the LiDAR extrinsic far off (10 deg / 1 m) that depth is so wrong that
// the solve ends away from the truth (generated windows: the baseline direction up to 22 deg
// off), and the stereo clouds rectified with it mislead the LiDAR-stereo solve. Matches
// between the left and the right image constrain R and the direction of t through the epipolar
// constraint alone, whatever the LiDAR says; the baseline length stays the caller's.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

struct FeatureStereoSettings {
  int max_features_per_image = 2000;     ///< ORB key points per image
  double ratio_test = 0.8;               ///< Lowe's test on the two nearest descriptors
  int refine_window_px = 11;             ///< sub-pixel refinement of each match (pyramidal LK)
  double max_forward_backward_px = 0.3;  ///< right -> left tracking must come back this close
  double ransac_threshold_px = 1.0;      ///< essential-matrix RANSAC over the window's matches
  double huber_px = 0.5;                 ///< robust loss of the epipolar refinement
  int min_inliers = 200;                 ///< fewer: no estimate
  /// Larger 1-sigma uncertainties (after scaling with the residuals' variance) make the estimate
  /// not usable: the matches do not constrain the rotation or the baseline direction.
  double max_sigma_rot_deg = 0.05;
  double max_sigma_direction_deg = 1.0;
  int threads = 2;
};

struct FeatureStereoResult {
  bool ok = false;  ///< enough inliers and both sigmas within the settings' bounds
  /// R and the baseline direction from the matches, |t| from the guess the caller gave (not ok:
  /// the guess, or the loose estimate when only its sigmas are beyond the bounds).
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  int matches = 0;                 ///< after the ratio and forward-backward tests, over the window
  int inliers = 0;                 ///< within the RANSAC threshold of the refined epipolar geometry
  double rms_px = 0;               ///< epipolar (Sampson) residual of the inliers
  double sigma_rot_deg = 0;        ///< largest 1-sigma of the rotation
  double sigma_direction_deg = 0;  ///< largest 1-sigma of the baseline direction
  double seconds = 0;
  std::string message;  ///< why not ok
};

/// Estimates R and the baseline direction of `T_right_left` from ORB matches between each
/// keyframe's left and right grey images (as delivered, intrinsics of `rig`), refined to sub-pixel
/// with LK, an essential matrix by RANSAC over all keyframes' matches together (one rig), and a
/// Ceres refinement of the Sampson distance (residuals/sampson_epipolar.h). `T_right_left_guess`
/// picks which of the essential matrix's poses (the rotation nearer to it, the baseline on its
/// side) and gives the length (it must have one); nothing else of it is used.
FeatureStereoResult estimateStereoFromFeatures(const std::vector<const Keyframe*>& window,
                                               const StereoRig& rig,
                                               const Eigen::Isometry3d& T_right_left_guess,
                                               const FeatureStereoSettings& settings = {});

}  // namespace tescalib
