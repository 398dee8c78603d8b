// Joint calibration (the paper's first future-work item): the LiDAR-stereo fine residuals and the
// left-right photometric residuals in one Ceres problem over both extrinsics.
//
// Coupling in both directions:
// - photometric -> LiDAR: a key point's 3D point is where its left ray meets its LiDAR face, and
//   the face moves with T_cam_lidar, so the photometric residuals depend on both extrinsics;
// - LiDAR-stereo -> left-right: a stereo point is F(d) = R_rect^T K_rect^-1 (u, v, 1) f b / d.
//   It is linearised in T_right_left around the rectification the cloud was computed with: the
//   baseline length enters exactly (F scales with |t_right_left|), the right camera's rotation
//   through a first-order correction of the measured disparity (a rotated right camera shifts
//   the matched pixel), so a change of T_right_left moves the stereo points inside the solve.
//   What the linearisation leaves out (second order, the baseline direction, SGBM itself) is
//   handled by re-rectifying between outer iterations when T_right_left's rotation or direction
//   moved by more than `co.rerectify_deg`. Re-rectifying alone (no rotation term) is not enough:
//   the outer loop then contracts by only ~0.7 per iteration, because the yaw of the
//   right camera (a constant disparity offset) and the LiDAR's forward offset pull on each other
//   through the clouds, which a solve that holds the clouds fixed cannot see.
#pragma once

#include <array>
#include <vector>

#include "tescalib/core/solvers/co_calibration.h"

namespace tescalib {

struct JointCalibrationSettings {
  CoCalibrationSettings co;  ///< solvers' settings, clouds, tolerances (stable_*, rerectify_deg)
  int max_outer = 15;        ///< outer iterations (re-associate, re-rectify, one joint solve)
  int ceres_iterations = 10;
  /// Photometric residual sigma (grey levels) that weighs it against the LiDAR residuals (which
  /// are already in noise units); <= 0: the robust spread of the initial left-right solve's.
  double photometric_sigma = -1;
  /// Per-axis model error of the joint estimate (camera axes, 1 sigma), added on top of the
  /// co-calibration covariances evaluated at it: the joint estimate is less accurate than the
  /// alternation's (in the joint problem each residual set also pulls the other extrinsic, with
  /// the model errors of its own). Fitted by the method of moments on the converged of the co
  /// benchmark's 30 starts (the held-out check: doc/benchmarks.md); the model_sigma_* below.
  /// The co-calibration LiDAR model error these were fitted on top of: the one of a
  /// co-calibration that does not propagate the stereo pair's uncertainty into the LiDAR
  /// covariance, as the joint covariance solves do not; used instead of
  /// CoCalibrationSettings::model_sigma_lidar_*.
  std::array<double, 3> co_model_sigma_lidar_rot_deg = {0.0187, 0.0063, 0.0186};
  std::array<double, 3> co_model_sigma_lidar_trans_m = {0.0019, 0.0019, 0.00275};
  /// The same for the co-calibration stereo model error the joint one was fitted on top of; used
  /// instead of CoCalibrationSettings::model_sigma_stereo_*.
  std::array<double, 3> co_model_sigma_stereo_rot_deg = {0.0, 0.0, 0.0};
  std::array<double, 3> co_model_sigma_stereo_trans_m = {0.0007, 0.00027, 0.00019};
  /// Fitted with the two initial rounds below on the 29 converged of the benchmark's 30 starts;
  /// held-out check, 54 starts: mean NEES 4.55 (6.98 without a joint model error).
  std::array<double, 3> model_sigma_lidar_rot_deg = {0.0099, 0.0106, 0.0};
  std::array<double, 3> model_sigma_lidar_trans_m = {0.00121, 0.00400, 0.0};
  std::array<double, 3> model_sigma_stereo_rot_deg = {0.0027, 0.0018, 0.0015};
  std::array<double, 3> model_sigma_stereo_trans_m = {0.00040, 0.00030, 0.0};
};

/// Initialises with co-calibration rounds (the joint problem's projective associations need a
/// start within their basin): with `co.stereo_from_features` (default) two, round 1 taking the
/// pair from left-right feature matches and solving LiDAR-stereo with the wide-basin search,
/// round 2 photometric (coarse-to-fine, on that LiDAR estimate's depth) and LiDAR-stereo (fine
/// only after a converged round 1); without it, or when the matches give no pair, photometric
/// first. The rounds run without the alternation's yaw handover, split-window check, sensitivity
/// to the pair and second opinion; the joint estimate gets the second opinion at the end (when
/// it moved CoCalibrationSettings::confirm_beyond_* from the guess), and is converged only when
/// its two covariance solves (below) converged at it. On the co benchmark's 30 starts the two
/// rounds converge on 29; one photometric-first round leaves 10 unconverged (2 with too few LiDAR
/// residuals after a round-1 pair 0.2-0.25 deg off, 8 still moving after 15 outer
/// iterations). Then it runs the joint outer iterations. Returns the co-calibration result type:
/// `lidar.T_cam_lidar`, `stereo.T_right_left`, their covariances (co-calibration's, evaluated at
/// the joint estimate by one warm solve of each kind, plus the joint model error above; the joint
/// problem's own marginals are over-confident), the trust flags of those solves, `rounds` = outer
/// iterations, `stable` = the last update was below the tolerance; `lidar_covariance_given_stereo`
/// is the LiDAR covariance (the joint one does not propagate the pair's), `features`,
/// `rectifications` and `rematches` count the initial rounds too, the alternation's other
/// bookkeeping (extrapolations, rejected, yaw_handovers, lidar_first, the sensitivity to the
/// pair, coupling) is zero.
/// The keyframes' meshes need every face's normal fitted (LidarMeshSettings::sampled_faces = 0):
/// the photometric residuals intersect each key point's ray with its face along that normal, and
/// key points lie on any face. A window whose meshes fit only a sample is refused (converged =
/// false, the initial guesses, a message saying so).
CoCalibrationResult jointCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar_init,
                                   const Eigen::Isometry3d& T_right_left_init,
                                   const JointCalibrationSettings& settings = {});

}  // namespace tescalib
