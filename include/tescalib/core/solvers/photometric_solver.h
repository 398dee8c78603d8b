// Left-right camera calibration (paper, "Left and right camera calibration"): T_right_left from
// a photometric objective over key points whose depth comes from the LiDAR mesh.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

struct PhotometricSettings {
  int cell_size = 14;          ///< one key point per cell of this many pixels (Stereo DSO style)
  double min_gradient = 12.0;  ///< grey levels per pixel (Scharr / 32)
  int max_keypoints_per_keyframe = 900;
  double gradient_weight_c = 50.0;  ///< c of w_p = c^2 / (c^2 + |grad I|^2)
  /// Grey levels, on the norm of a key point's whole pattern (8 pixels) residual, as Ceres applies
  /// a loss to a residual block: about 9 / sqrt(8) = 3.2 grey levels per pixel when all deviate
  /// alike (Stereo DSO applies its Huber per pixel).
  double huber = 9.0;
  int pyramid_levels = 3;  ///< coarse-to-fine: 1/4, 1/2, 1
  int iterations_per_level = 25;
  double occlusion_tolerance = 0.05;  ///< relative depth difference tolerated in the right view
  double min_depth = 2.0, max_depth = 60.0;  ///< m, key point depth
  /// Full-resolution key points only where the LiDAR depth is smooth: within this many pixels
  /// the mesh depth varies by at most `smooth_depth_tolerance` (relative). A LiDAR extrinsic error
  /// moves the mesh in the image (1 deg is 12 px at KITTI's focal length); at a depth edge a key
  /// point then takes the depth of the wrong surface, on a smooth surface nearly the right one.
  /// The coarser pyramid levels keep every key point (edges widen the basin). 0 (default): off.
  /// Measured: 8 px helps with the LiDAR 1 deg / 10 cm off on generated
  /// 20-keyframe windows, but costs accuracy on real KITTI and inside co-calibration.
  int smooth_depth_radius_px = 0;
  double smooth_depth_tolerance = 0.1;
  int min_keypoints = 150;
  double max_sigma_rot_deg = 0.05;  ///< an axis looser than this (1 sigma) is unconstrained
  double max_sigma_trans_m = 0.01;
  /// 1-sigma model error per camera axis added to the covariance (calibrated so that mean NEES
  /// is 6 over 30 independent generated urban windows of 10 keyframes).
  std::array<double, 3> model_sigma_rot_deg = {0.0023, 0.0004, 0.0022};
  std::array<double, 3> model_sigma_trans_m = {0.00016, 0.00028, 0.00018};
  /// Photo-consistency: a solve is declared converged only when its median key point pattern
  /// residual is at most this share of the same with the right image looked up 4 px off
  /// (PhotometricResult::consistency_ratio). Measured: 0.14 on generated windows and
  /// 0.25-0.29 on the real KITTI ones at their estimates, 0.94-0.995 for starts 2-3 deg off that
  /// matched nothing and whose covariance still said 0.003 deg.
  double max_consistency_ratio = 0.6;
  double max_correction_rot_deg = 10.0;
  double max_correction_trans_m = 1.0;
  int threads = 2;
  /// Keep |t_right_left| at the initial guess' length (a stiff prior; rotation and baseline
  /// direction stay free). Co-calibration sets it: there the LiDAR-given stereo scale decides the
  /// length, and a free length can absorb a large LiDAR depth error into a wrong local minimum.
  bool fix_baseline_length = false;
  /// Free depth: at the finest `depth_free_levels` pyramid levels every key point's depth gets a
  /// log-scale correction rho (depth e^rho times the LiDAR's) with the prior rho ~ N(0, sigma^2),
  /// as Stereo DSO refines its points' depth. The LiDAR depth then only sets the scale (or nothing,
  /// with `fix_baseline_length`): a LiDAR extrinsic error no longer pulls the baseline direction,
  /// which the vertical disparities fix; the price is a weaker yaw and scale (their information
  /// comes from the LiDAR depth). The prior is robust (Cauchy). 0 (the paper): the LiDAR depth.
  double depth_prior_sigma = 0.0;
  int depth_free_levels = 1;
  /// With free depth: the LiDAR extrinsic's own error as a 6-DoF nuisance xi ([phi; tau] about and
  /// along the camera axes) shared by every key point, with a Gaussian prior of these per-axis
  /// sigmas: a key point's log depth then follows D xi (D: how its ray's intersection with its
  /// face moves with the LiDAR extrinsic) plus its own correction (prior `depth_prior_sigma`). A
  /// LiDAR extrinsic error moves the depths as it does (the road's with the LiDAR's height, the
  /// surfaces facing the camera with its forward offset) instead of biasing the baseline length
  /// through the depth priors. Either <= 0: no nuisance (each depth anchored on its own).
  double lidar_error_sigma_rot_deg = 0.0;
  double lidar_error_sigma_trans_m = 0.0;
};

/// A key point of the photometric objective: the strongest gradient of its cell with LiDAR depth.
struct KeyPoint {
  double u = 0, v = 0;  ///< full-resolution left pixel
  int face = -1;        ///< LiDAR face under it
  double grad2 = 0;     ///< squared gradient magnitude
};

/// Key points of one keyframe (one per cell, the mesh depth `md` rendered in the left camera;
/// only on smooth depth when `settings.smooth_depth_radius_px` > 0).
std::vector<KeyPoint> selectKeyPoints(const Keyframe& kf, const MeshDepth& md,
                                      const PhotometricSettings& settings);

struct PhotometricResult {
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  bool converged = false;
  int iterations = 0;     ///< Ceres iterations over all levels
  double final_cost = 0;  ///< mean Huber cost per residual at full resolution
  int keypoints = 0;      ///< key points with LiDAR depth (all keyframes)
  int occluded = 0;       ///< key points hidden in the right image (last level)
  int inliers = 0;        ///< key points used at the last level
  /// Median pattern residual at the estimate over the same with the right image looked up 4 px
  /// off (mean of +-x, +-y): near 1 when the pose matched nothing but texture.
  double consistency_ratio = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector2d> brightness;  ///< per keyframe (a, b): I_r = e^a I_l + b
  /// Without `covariance_known` a placeholder (identity), not an uncertainty.
  Matrix6d covariance = Matrix6d::Identity();
  /// The full-resolution problem's covariance was computed (false when the solve ended before
  /// it: too few key points, a bad initial guess, ...; or when the problem was rank-deficient,
  /// a direction of the pose constrained by no key point: then not converged either).
  bool covariance_known = false;
  /// How the LiDAR extrinsic that gave the key points' depth moves this estimate: d[phi; tau] of
  /// T_right_left per d[phi; tau] of T_cam_lidar (the brightness parameters marginalised; first
  /// order, from the full-resolution problem). `covariance` is conditional on T_cam_lidar being
  /// exact; with its covariance P the marginal one adds S P S^T (addLidarUncertainty). Zero with
  /// free key point depth.
  Matrix6d lidar_sensitivity = Matrix6d::Zero();
  /// With the LiDAR error nuisance (PhotometricSettings::lidar_error_sigma_*): its estimate,
  /// [phi; tau] of the LiDAR extrinsic's error in the camera frame, to first order; else zero.
  Vector6d lidar_error = Vector6d::Zero();
  bool observable[6] = {false, false, false, false, false, false};
  /// The covariance the `observable` flags judge in directions (weakDirections, in units of
  /// max_sigma_*), the weakest first; empty when not computed.
  std::vector<WeakDirection> weak_directions;
  WeakDirection weakest() const { return weakestOf(weak_directions); }
  double seconds = 0;
  std::string message;
};

/// Solves T_right_left over the window from `T_init`, with the LiDAR extrinsic `T_cam_lidar`
/// giving the key points' depth. The keyframes' images are used as delivered (rectified with
/// the rig's intrinsics `rig.left`, `rig.right`).
PhotometricResult solvePhotometric(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar,
                                   const Eigen::Isometry3d& T_init,
                                   const PhotometricSettings& settings = {});

/// Per-axis trust flags (PhotometricResult::observable) from a covariance over [phi; tau]: an
/// axis is trusted when its sigma is within settings.max_sigma_*; true when every axis is.
bool trustFlags(const Matrix6d& covariance, const PhotometricSettings& settings,
                bool observable[6]);

/// Adds what the LiDAR extrinsic's uncertainty `cov_cam_lidar` ([phi; tau], rad, m) does to the
/// estimate, S P S^T with S = `result->lidar_sensitivity`, to `result->covariance`.
void addLidarUncertainty(PhotometricResult* result, const Matrix6d& cov_cam_lidar);

}  // namespace tescalib
