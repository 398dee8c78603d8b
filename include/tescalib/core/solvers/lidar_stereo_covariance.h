// Uncertainty of the LiDAR-stereo estimate (paper, "Uncertainty Analysis under Different Driving
// Scenarios"): the information of the fine stage's residuals at the estimate and the covariances
// of LidarStereoResult built from it.
//
// Analytic Jacobian of r = (R m)^T (R q + t - s) / sigma at the estimate:
//   dr/dphi = (m x (t - s))^T / sigma,  dr/dtau = m^T / sigma  (m, q already rotated).
// H = sum w J^T J is the information of eq. residual_uncertainty: the residuals are already
// divided by their noise-model sigma (J_w Sigma J_w^T of the paper), so H^-1 is the paper's
// covariance. It assumes independent residuals; neighbouring residuals share SGBM and
// association errors, so it is over-confident. The published covariance is the cluster-robust
// sandwich H^-1 (sum_c g_c g_c^T) H^-1 with g_c = sum_{i in c} w_i J_i^T r_i over clusters
// c = (keyframe, image cell): errors shared inside a cell count once (never below the paper's
// covariance scaled by the residuals' robust variance). Neither sees errors common to the whole
// window (association and matching biases), so a calibrated model-error covariance is added.
// With the stereo scale and yaw free, the pose shares information with them: the covariance is
// the pose block of the full inverse (the nuisance parameters marginalised), otherwise a window
// that cannot separate the LiDAR's forward offset from the clouds' scale or yaw would look well
// constrained.
#pragma once

#include <cstddef>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/lidar_stereo_update.h"

namespace tescalib {

/// Fills the covariances of `result` (information, covariance_model, covariance_statistical,
/// covariance, the bias sensitivities, stereo_scale_variance, the disparity offset, the trust
/// flags and weak directions) and final_cost, residual_scale and keyframe_information from the
/// fine stage's last association set at `estimate` (a window of `window_size` keyframes).
/// Returns whether every axis is constrained (false without associations, or with a singular
/// information matrix: then the covariances are 1e6 I and covariance_known stays false).
bool estimateLidarStereoCovariance(const LidarStereoEstimate& estimate,
                                   const LidarStereoSettings& settings, size_t window_size,
                                   LidarStereoResult* result);

/// The factor by which `result`'s model-error floors grow for its window's f B: the reference
/// f B (LidarStereoSettings::model_floor_focal_baseline_px_m) over the window's (1 when unknown).
double floorFocalBaselineFactor(const LidarStereoResult& result,
                                const LidarStereoSettings& settings);

/// The statistical part plus the common biases through `sensitivity`
/// (LidarStereoResult::bias_sensitivity or bias_sensitivity_held), the disparity offset's sigma
/// that of disparityBiasSigma.
Matrix6d withLidarStereoBiases(const LidarStereoResult& result, const LidarStereoSettings& settings,
                               const LidarStereoBiasSensitivity& sensitivity);

/// The covariance of what the window constrains (the trust flags): the statistical part plus
/// the common biases, with the clouds' scale and yaw held (they absorb only a uniform offset).
Matrix6d constrainedCovariance(const LidarStereoResult& result,
                               const LidarStereoSettings& settings);

/// Whether a surface normal (camera frame, of any length) is the ground's for the covariance's
/// ground disparity offset (LidarStereoSettings::model_sigma_ground_disparity_px): within 37 deg of
/// camera y.
bool onGround(const Eigen::Vector3d& normal);

/// Whether a surface normal (camera frame, of any length) is a lateral surface's for the
/// covariance's lateral disparity offset and tilt (LidarStereoSettings::model_sigma_lateral_*): not
/// the ground's, and within 45 deg of camera x.
bool onLateral(const Eigen::Vector3d& normal);

/// The sigma (px per unit of normalised column) of the ground's disparity tilt across the image
/// for this result's rectification roll and its clouds' column low-pass
/// (LidarStereoSettings::model_sigma_ground_tilt_px_per_deg and _low_passed_px_per_deg).
double groundTiltSigma(const LidarStereoResult& result, const LidarStereoSettings& settings);

}  // namespace tescalib
