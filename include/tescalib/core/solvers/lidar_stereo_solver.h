// LiDAR-stereo calibration over a window of keyframes (paper, "Coarse Calibration" and "Fine
// Calibration"): T_cam_lidar from the LiDAR meshes and the stereo clouds. The stages:
// lidar_stereo_association.h (eq. KD6 and the projective association), lidar_stereo_coarse.h,
// lidar_stereo_fine.h (with lidar_stereo_update.h, one Ceres update), lidar_stereo_covariance.h
// (the uncertainty analysis); solveLidarStereoSearch and checkWindowHalves are defined in
// lidar_stereo_search.cpp and lidar_stereo_halves.cpp.
#pragma once

#include <array>
#include <atomic>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

/// Where the split-window check (checkWindowHalves) starts the window's two halves.
enum class HalvesStart {
  /// From the window's estimate, fine stage only: tests the noise model around its minimum.
  kEstimate,
  /// From the estimate and, when those halves disagree or both leave the estimate (beyond
  /// halves_chi2_limit), again from the window's initial guess (both stages): a half that then
  /// settles elsewhere than from the estimate (halvesStartsApart) shows a window with more than
  /// one minimum, and the solve is refused (its covariance widened along the difference) rather
  /// than its covariance scaled. The default.
  kEstimateThenInitialGuess,
  /// From the initial guess (both stages): two calibrations independent of the window's path.
  kInitialGuess,
  /// From the estimate and always again from the window's initial guess (both stages), refusing
  /// as kEstimateThenInitialGuess does: for an estimate that an iteration's path can leave
  /// anywhere along a valley, where halves started from it stay with it (co-calibration's final
  /// check, CoCalibrationSettings::halves_always_from_initial_guess).
  kEstimateAndInitialGuess,
};

struct LidarStereoSettings {
  // Coarse stage (eq. KD6 association, eq. point_plane_normal_obj).
  bool run_coarse = true;
  /// LiDAR faces per keyframe drawn from the mesh's sample by sampleFaces (`LidarMesh::sample`, the
  /// faces with fitted normals; LidarMeshSettings::sampled_faces, 4000 by default).
  int coarse_faces_per_keyframe = 1500;
  /// ... and at most this many over the window: the coarse stage only brings the estimate into
  /// the fine stage's basin, and 15000 faces do that as well as 30000 (a 20-keyframe generated
  /// window: the same success from 10 deg / 1 m and the same final errors, coarse stage 1.5x
  /// faster). Windows of up to 10 keyframes keep 1500 per keyframe.
  int coarse_faces_per_window = 15000;
  int coarse_stereo_points_per_keyframe = 8000;  ///< stereo points in the 6-D search tree
  double normal_weight = 0.5;                    ///< w of eq. KD6 (m per unit normal difference)
  double normal_residual_weight = 0.5;           ///< w of eq. point_plane_normal_obj
  std::vector<double> coarse_gates = {2.0, 1.0, 0.5};  ///< 6-D association gate per stage, m
  int coarse_reassociations = 8;   ///< per stage, until the update is below the threshold
  double coarse_loss_scale = 2.0;  ///< Cauchy scale (normalised residual units)
  // Fine stage (eq. point_point_normal_obj, projective association).
  bool run_fine = true;
  int fine_faces_per_keyframe = 4000;  ///< from the mesh's sample, like the coarse faces
  /// At most this many projective re-associations; a fine stage that has not settled by then is
  /// judged by where its last updates head (unsettledDrift). A coarse stage that leaves the
  /// depth axis tens of centimetres off (a start 6 deg / 0.6 m away) needs about 15.
  int fine_reassociations = 20;
  double fine_huber = 1.5;       ///< Huber threshold in sigma units
  double fine_gate_sigma = 8.0;  ///< associations beyond this many sigma are dropped
  /// px; > 0: the fine residual's derivative follows the stereo surface (fineResidualNormal). As
  /// the estimate moves, a face's projection slides along the stereo surface, and where that
  /// surface is tilted against the face (grazing walls, depth edges, the mesh's chords) the
  /// distance to the face changes with it. With the face's normal alone (0, the default) the
  /// solve does not see this, each re-association moves the estimate on in the direction of the
  /// last (0.8-0.95 of each update on some random rigs) and the fine stage settles beyond what one
  /// step's covariance allows. The stereo surface's normal comes from a weighted affine fit of the
  /// disparity over the (2 h + 1)^2 pixels around the projection (stereoSurfaceNormal; 6 is the
  /// size studied, doc/limitations.md); the ground's faces keep their own normal.
  int fine_stereo_normal_px = 0;
  double max_depth = 40.0;  ///< m; farther LiDAR faces are not associated
  /// Also estimate a scale of the stereo clouds (= true baseline / the baseline they were
  /// computed with): a real pair's f x B is known to about 1 % (the KITTI recordings' stereo
  /// disparity exceeds the LiDAR-predicted one by 0.8-2.0 %), and held at 1 that error moves the
  /// estimate along the optical axis by about 5 cm per % (tescalib_simulate --realism-set
  /// baseline_scale). Off, the scale is held at 1.
  bool estimate_stereo_scale = true;
  /// The scale stays within [1 / max_stereo_scale, max_stereo_scale]: a baseline 30 % off is
  /// beyond any stereo rig's calibration, and a free scale can collapse a LiDAR-stereo solve that
  /// starts far off (seen on KITTI: scale 0.5 and the LiDAR 2 m away). A solve whose scale ends
  /// on the bound is not converged (its minimum is the bound's, not the data's).
  double max_stereo_scale = 1.3;
  /// Also estimate a yaw of the right camera relative to the rectification the clouds were
  /// computed with (it shifts every disparity by f yaw (1 + x_r^2), a depth error growing with
  /// depth squared that the rigid T would otherwise absorb along the optical axis). Used by
  /// co-calibration, where the clouds' rectification is itself being estimated; within
  /// +-max_stereo_yaw_deg.
  bool estimate_stereo_yaw = false;
  double max_stereo_yaw_deg = 1.0;
  /// The coarse stage estimates the stereo scale and yaw too (when they are estimated at all);
  /// off, it holds them at their start values and only the fine stage estimates them. From a far
  /// start the coarse stage can otherwise slide along the valley where the LiDAR's forward offset,
  /// the clouds' scale and their yaw trade against each other (a co-calibration start 3 deg /
  /// 0.3 m off can end 1.6 m off along z).
  bool coarse_estimates_stereo_nuisances = false;
  /// Start of the yaw (rad): a warm start knows it from the previous solve; starting at 0 with
  /// clouds 0.3 deg off in yaw, the fine stage's gate can reject nearly every association.
  double initial_stereo_yaw_rad = 0.0;
  /// Start of the scale (with estimate_stereo_scale, clamped to its bounds): re-solves on the
  /// clouds of a solve that estimated it (the split-window halves, co-calibration's sensitivity
  /// and second opinion) start from that solve's scale, not from 1.
  double initial_stereo_scale = 1.0;
  // Noise model (paper eq. lidar_noise and the disparity noise).
  double lidar_range_sigma = 0.02;     ///< m
  double lidar_beam_sigma_deg = 0.02;  ///< beam direction, deg
  double disparity_sigma = 0.35;       ///< px
  // Termination and honesty.
  int ceres_iterations = 8;
  double converge_rot_deg = 2e-4;  ///< stop re-associating below this update
  double converge_trans_m = 2e-5;
  double fine_settle_rot_deg = 1e-3;  ///< the fine stage has settled below this update
  double fine_settle_trans_m = 3e-4;
  /// The fine stage has settled only where, besides, the creep of its last updates would carry
  /// the estimate on (walkAhead) by less than this fraction of the trust limits max_sigma_*: a
  /// stage that moves the same way by 0.4-0.5 mm per update can take one update below
  /// fine_settle_trans_m and stop wherever that happens (on a generated residential drive of a
  /// random rig, starts that stopped 24 mm before and 16 mm after the truth along the optical
  /// axis). A stage that has not settled by fine_reassociations is judged by where it heads
  /// (unsettledDrift). On the development rigs 0.25 moves no urban start by more than 0.2 mm and
  /// 0.1 also stops good ones (tescalib_eval --fine-settle-walk; doc/limitations.md).
  double fine_settle_walk = 0.25;
  /// The fine stage's fixed-point gain (lidar_stereo_fixed_point.h) is measured with probes of
  /// this fraction of the trust limits max_sigma_* per axis and carries the covariance, the bias
  /// sensitivities and so the trust flags to the fixed point; 0 (the default): not measured, the
  /// covariance of one Gauss-Newton step at the end point, with which the per-axis floors and
  /// the trust limits were set (doc/limitations.md, "The fine stage walks further than one step").
  double fine_gain_probe = 0.0;
  /// Eigenvalues of the fine stage's iteration Jacobian M below this magnitude are the probes'
  /// jitter, not feedback, and are left out of the gain: on planes, where M is 0, the probes
  /// measure up to 0.22 (LidarStereoSolver.ReassociationOnPlanesDoesNotMoveTheFixedPoint).
  double fine_gain_noise_floor = 0.3;
  int min_inliers = 300;
  /// An axis whose sigma is looser than this (1 sigma; the statistical part plus the common
  /// biases through this window's sensitivity with the clouds' scale and yaw held,
  /// LidarStereoResult::bias_sensitivity_held, without the per-axis floor) is unconstrained. With
  /// the nuisances estimated this sigma can exceed the published one's (which marginalises them).
  double max_sigma_rot_deg = 0.1;
  double max_sigma_trans_m = 0.01;
  // Covariance: clusters of the sandwich estimator (image cells per keyframe), and the model
  // error added to it (errors shared by the whole window, which no residual statistic sees):
  // window-common measurement biases of unknown sign (one disparity offset for every stereo
  // point, one range offset for every LiDAR point), propagated through this window's geometry
  // (LidarStereoResult::bias_sensitivity), so a scene that constrains an axis weakly also lets
  // such a bias move it further; plus a 1-sigma floor per camera axis. Calibrated on independent
  // generated urban, residential and highway windows (NEES by scene: doc/benchmarks.md); real
  // data may need larger values.
  int cov_cells_x = 8;
  int cov_cells_y = 3;
  /// Residuals also share errors along the LiDAR's rings: a laser's range offset and elevation
  /// error are the same in every keyframe (doc/scene_generator.md, real sensors' errors). The
  /// sandwich clusters both ways (twoWayClusterCovariance) by image cell and by this many
  /// adjacent rings (a face spans two); 0: by image cell alone.
  int ring_cluster_rings = 2;
  /// Prior 1-sigma (m) of a range offset per LiDAR ring (range-image row), estimated with the
  /// pose by the fine stage: a multi-beam LiDAR's lasers each measure range with an offset of
  /// their own (centimetres after the factory's calibration), which moves the rings of the road
  /// against each other and tilts the mesh's ground. The offsets' uncertainty enters the
  /// covariance (marginalised). 0: not estimated (the default: the model-error floors and the
  /// benchmarks are calibrated without it); 0.1 m, a loose bound on a factory-calibrated laser's
  /// offset, for LiDARs whose lasers disagree (the data fix the offsets: the estimate moves by a
  /// few thousandths of a degree between 0.05 and 0.3 m).
  double ring_range_sigma_m = 0.0;
  /// Sigma (m) of the mean of the rings' offsets (RingOffsetMean): their common part is not
  /// estimated, since it moves the faces in view as the camera's optical axis does.
  double ring_range_mean_sigma_m = 0.001;
  double model_sigma_disparity_px = 0.05;
  /// Measure the window-common disparity offset the fine residuals show
  /// (LidarStereoResult::disparity_offset_px) and, where the window determines it
  /// (disparityOffsetMeasured: beyond `disparity_offset_significance` times its own sigma, and
  /// that sigma within `max_disparity_offset_sigma_px`) and it is larger than
  /// `model_sigma_disparity_px`, use it as the bias term's sigma. Generated windows show at most
  /// 0.04 px (sigma 0.005-0.01), real KITTI windows (clouds rectified with KITTI's own
  /// calibration) 0.15-0.27 px (sigma 0.03-0.065); a road-only window cannot tell an offset from
  /// a tilted road (sigma 5 px).
  bool measure_disparity_offset = true;
  double disparity_offset_significance = 3.0;
  double max_disparity_offset_sigma_px = 0.25;
  double model_sigma_range_m = 0.004;
  /// 1-sigma of a window-common relative disparity scale (an error of f B; see bias_sensitivity).
  double model_sigma_disparity_scale = 0.0;
  /// 1-sigma (px) of a window-common disparity offset of the ground alone (stereo points whose
  /// surface normal lies within 37 deg of the camera's y axis): a matcher's bias on the surface it
  /// sees most foreshortened, which tilts the stereo ground and moves the estimate about the
  /// camera's x axis by an amount that depends on the rig (focal length, baseline, camera height,
  /// where the LiDAR sits), through this window's geometry (bias_sensitivity column 3).
  /// Generated drives without noise show -0.03 to -0.06 px (tescalib_error_budget).
  double model_sigma_ground_disparity_px = 0.06;
  /// 1-sigma (px per unit of normalised image column x, per degree of the rectification's roll)
  /// of a tilt of the ground's disparity error across the image (an error of b x px): a pair
  /// whose right camera sits off the left camera's x axis is rectified about the optical axis by
  /// atan(t_y / B), and the matched road then tilts across the image (none on a pair rectified
  /// as delivered), which turns the estimate about the camera's z axis by 0.2-1.2 deg per px
  /// (shorter baselines and focal lengths move it more), through this window's geometry
  /// (bias_sensitivity column 4). tescalib_error_budget's road fit on generated urban drives of
  /// eight random rigs (rolls 0.16-1.05 deg): rms tilt per degree of roll 0.13 px for clouds
  /// matched sharp, 0.12 px with a column low-pass of 0.4 px, 0.072 and 0.066 px with one of 0.8
  /// and 1.2 px (StereoSettings::rectified_vertical_blur_px). The first sigma holds for clouds
  /// matched with a low-pass below `model_ground_tilt_low_pass_px`, the second from it on.
  double model_sigma_ground_tilt_px_per_deg = 0.13;
  double model_sigma_ground_tilt_low_passed_px_per_deg = 0.072;
  double model_ground_tilt_low_pass_px = 0.8;
  /// 1-sigma (px) of a window-common disparity offset of the lateral surfaces (normal within
  /// 45 deg of camera x: walls and parked cars beside the road, whose disparity changes along
  /// the rows), and 1-sigma (px per unit of normalised image column x) of a tilt of their
  /// disparity error across the image (b x px: the walls on the left against those on the
  /// right). The matcher's error on these surfaces differs from the rest of the scene's and from
  /// one rig to another: tescalib_error_budget's lateral fit on generated urban drives of seven
  /// random rigs and the default one gives offsets -0.030 to +0.013 px (rms 0.013) and tilts
  /// -0.037 to +0.050 px (rms 0.029). Left and right walls sit on opposite sides of the image,
  /// so both turn the estimate about the camera's y axis (0.1-1.4 deg per px of offset, 0.5-1.0
  /// per px of tilt on those rigs), through this window's geometry (bias_sensitivity columns 5
  /// and 6).
  double model_sigma_lateral_disparity_px = 0.015;
  double model_sigma_lateral_tilt_px = 0.03;
  /// The per-axis floors hold for a pair with f B = `model_floor_focal_baseline_px_m` (px m, the
  /// default rig's 718.9 px x 0.54 m); a window's floors scale with that over its own f B (the
  /// first keyframe's rectified focal length times baseline): a disparity error of a given size
  /// moves depth, and through it the estimate, by 1 / (f B). Fitted on generated urban windows of
  /// the default rig and of random rigs (doc/limitations.md).
  std::array<double, 3> model_sigma_rot_deg = {0.0056, 0.00385, 0.0056};
  std::array<double, 3> model_sigma_trans_m = {0.00105, 0.000525, 0.002275};
  double model_floor_focal_baseline_px_m = 388.2;
  double max_correction_rot_deg = 25.0;  ///< a larger correction from the start is divergence
  double max_correction_trans_m = 2.5;
  /// Split-window check of the noise model (checkWindowHalves), run after a converged solve:
  /// the first and the second half of the window (at least `min_keyframes_per_half` keyframes
  /// each) are solved again on their own, fine stage only, from the estimate; when their
  /// difference is beyond `halves_chi2_limit` (chi-square, 6 DoF, of their summed covariances;
  /// 22.46 is the 99.9 % quantile) the data hold an error the model does not explain, and the
  /// covariance is scaled by chi2 / 6 (the trust flags are evaluated again with it).
  bool check_window_halves = true;
  /// Also on a solve whose fine stage did not settle (with enough associations): a window
  /// straddling a change of the extrinsic often does not, and its newer half then still says
  /// where the extrinsic went (Halves::second_T). The online calibrator sets it once an estimate
  /// is published, for its monitor.
  bool halves_when_unsettled = false;
  /// Where the halves start (HalvesStart): from the estimate and, when they disagree or leave
  /// it, again from the initial guess (the default); from the estimate only; or from the initial
  /// guess only (tescalib_eval --halves-start; doc/limitations.md).
  HalvesStart halves_start = HalvesStart::kEstimateThenInitialGuess;
  int min_keyframes_per_half = 2;
  double halves_chi2_limit = 22.46;
  /// Wide-basin search (solveLidarStereoSearch; 0: off; co-calibration's LiDAR-stereo solves do
  /// not search): when the solve from the initial guess does not converge, solve again from the
  /// guess turned by +-`search_step_deg` about the camera's x axis, its y axis and both (8 more
  /// starts). Beyond about 15 deg a pitch error
  /// puts the LiDAR's faces outside the image (0 associations) and a yaw error slides along the
  /// yaw / lateral-translation valley into a wrong minimum; both are not declared converged.
  /// Generated urban, window 20: from 20 deg / 2 m 90 % instead of 50 %, from 15 deg / 1.5 m
  /// 100 % instead of 65 % (doc/benchmarks.md).
  double search_step_deg = 10.0;
  static constexpr double kMaxSearchStepDeg = 20.0;  ///< the largest step the callers accept
  /// Which of the 8 turned starts a search solves: -1 all of them; k >= 0 only start k mod 8.
  /// An online calibrator spreads the search over its successive solves, one start each, so
  /// that no solve costs more than about two plain ones (OnlineSettings::spread_search).
  int search_start = -1;
  int threads = 2;
  /// When set and true: stop at the next re-association or search start, not converged, message
  /// "cancelled" (a node shutting down does not wait for a long solve).
  const std::atomic<bool>* cancel = nullptr;
  bool cancelled() const { return cancel && cancel->load(std::memory_order_relaxed); }
};

/// How the window-common measurement biases move a LiDAR-stereo estimate: one column per bias
/// (LidarStereoResult::bias_sensitivity).
constexpr int kLidarStereoBiases = 7;
using LidarStereoBiasSensitivity = Eigen::Matrix<double, 6, kLidarStereoBiases>;

struct LidarStereoResult {
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();  ///< estimate
  Eigen::Isometry3d T_after_coarse = Eigen::Isometry3d::Identity();
  bool converged = false;  ///< fine stage settled, enough inliers, every axis constrained
  bool settled = false;    ///< the fine stage settled (its updates fell below fine_settle_*)
  /// Not converged only because some axis is not constrained (a degenerate scene, a highway):
  /// settled, enough associations, not diverged, no nuisance on its bound, not drifting.
  bool only_unconstrained = false;
  int iterations = 0;      ///< re-associations, coarse + fine
  double final_cost = 0;   ///< mean squared normalised fine residual (Huber-weighted)
  int coarse_inliers = 0;  ///< associations in the last coarse solve
  int fine_inliers = 0;    ///< associations in the last fine solve
  /// J^T W J of the final fine problem over the pose (with the stereo scale and yaw, when
  /// estimated, marginalised out: the Schur complement).
  Matrix6d information = Matrix6d::Zero();
  /// Each keyframe's share of the pose's information (window order): what it constrains. The
  /// pose block of its Gauss-Newton information before the clouds' scale and yaw (when
  /// estimated) are marginalised, so with them free the shares add up to more than
  /// `information` along what they absorb (the optical axis).
  std::vector<Matrix6d> keyframe_information;
  double stereo_scale = 1.0;  ///< estimated stereo scale (1 unless estimate_stereo_scale)
  /// Variance of `stereo_scale` (0 unless estimated): the same cluster-robust sandwich as
  /// `covariance_statistical` plus the common biases' share, scaled with the covariances by the
  /// split-window check. Co-calibration takes the baseline length from the scale and gives the
  /// left-right covariance this variance along the baseline.
  double stereo_scale_variance = 0.0;
  /// How the pose moves with the stereo scale along what the window leaves free between them
  /// ([phi; tau] per unit of relative scale, the pose re-solved with the scale held: the
  /// regression of the pose on the scale in the fine problem's covariance, carried through the
  /// fixed point's gain; zero unless the scale is estimated).
  Vector6d stereo_scale_sensitivity = Vector6d::Zero();
  double stereo_yaw_rad = 0.0;  ///< estimated right-camera yaw (0 unless estimate_stereo_yaw)
  /// Estimated range offset of each LiDAR ring (m, by range-image row: how much too long its
  /// ranges are; LidarStereoSettings::ring_range_sigma_m; empty when not estimated, 0 for a ring
  /// no association saw).
  std::vector<double> ring_range_offsets_m;
  /// Disparity offset (px, added to every stereo disparity) that best explains the fine
  /// residuals at the estimate, the pose re-solved with it (a linearised step; 0 when not
  /// measured: LidarStereoSettings::measure_disparity_offset off, or the clouds' yaw estimated).
  /// Where the window determines it (disparityOffsetMeasured), the covariance's disparity bias
  /// term uses max(model_sigma_disparity_px, |offset|).
  double disparity_offset_px = 0.0;
  double disparity_offset_sigma_px = 0.0;  ///< its cluster-robust sigma (0: not measured)
  double residual_scale = 1.0;  ///< robust std of the normalised residuals (1 if the model fits)
  /// Published covariance over [phi; tau] (rad, m): cluster-robust sandwich (see the solver).
  /// Without `covariance_known` a placeholder (identity, or 1e6 I), not an uncertainty.
  Matrix6d covariance = Matrix6d::Identity();
  /// The covariances were computed (false: no associations, or the information matrix was
  /// singular; then no axis is observable and a NEES of the placeholder means nothing).
  bool covariance_known = false;
  /// The paper's eq. residual_uncertainty, information^-1 (independent residuals assumed).
  Matrix6d covariance_model = Matrix6d::Identity();
  /// `covariance` without the model error: what this window's residuals alone constrain (scene
  /// comparisons use it; the `observable` flags add the bias terms, see max_sigma_*).
  Matrix6d covariance_statistical = Matrix6d::Identity();
  /// The fine stage's fixed-point gain (I - M)^-1 (lidar_stereo_fixed_point.h): `covariance`,
  /// `covariance_statistical` and the bias sensitivities are carried through it (the identity when
  /// it is not measured or not determined), and the contraction of its re-association, the
  /// spectral radius of M (0: re-association does not feed back; 1 or more: the window does not
  /// hold the fixed point, and the result is not converged).
  Matrix6d fixed_point_gain = Matrix6d::Identity();
  double fixed_point_contraction = 0.0;
  /// How window-common measurement biases move the estimate ([phi; tau] per unit bias, the
  /// nuisance parameters marginalised): column 0 per px of disparity offset of every stereo
  /// point, column 1 per m of range offset of every LiDAR point, column 2 per unit of relative
  /// disparity scale (every disparity d read as d (1 + k): an error of the pair's f B), column 3
  /// per px of disparity offset of the ground's stereo points alone, column 4 per px of a tilt of
  /// the ground's disparity error across the image (b x px at normalised column x). The published
  /// covariance adds h h^T sigma_b^2 for each (LidarStereoSettings::model_sigma_disparity_px,
  /// _range_m, _disparity_scale, _ground_disparity_px, _ground_tilt_px_per_deg times
  /// `rectification_roll_deg`, _lateral_disparity_px and _lateral_tilt_px).
  LidarStereoBiasSensitivity bias_sensitivity = LidarStereoBiasSensitivity::Zero();
  /// The same with the stereo scale and yaw held at their estimates (equal to
  /// `bias_sensitivity` when neither is estimated). The nuisances absorb a perfectly uniform
  /// offset, which a matcher's bias is not (generated clouds: -0.03 px on camera-facing surfaces
  /// only), so what the window constrains (the `observable` flags) takes these when the
  /// nuisances are estimated: on a 5-keyframe generated urban window whose forward offset the
  /// clouds' scale and yaw leave loose, the marginalised sensitivity would call tz trusted at
  /// 3-7 cm error (sigma 0.5-0.9 cm).
  LidarStereoBiasSensitivity bias_sensitivity_held = LidarStereoBiasSensitivity::Zero();
  /// The roll (deg) about the optical axis by which the window's stereo clouds were rectified:
  /// atan2(t_y, -t_x) of their left->right extrinsic (0 for a pair rectified as delivered).
  double rectification_roll_deg = 0.0;
  /// The column low-pass (px) the window's stereo clouds were matched with (the first
  /// keyframe's StereoCloud::vertical_low_pass_px; 0: none).
  double vertical_low_pass_px = 0.0;
  /// The window's rectified focal length times baseline (px m, the first keyframe's; 0 without).
  double focal_baseline_px_m = 0.0;
  /// Per axis: constrained within max_sigma_* (false: do not trust this axis of the estimate),
  /// judged with the common biases through `bias_sensitivity_held`.
  bool observable[6] = {false, false, false, false, false, false};
  /// What the window constrains, in directions: the eigen-directions of the covariance the
  /// `observable` flags judge, in units of max_sigma_* (weakDirections), the weakest first; a
  /// ratio above 1 is not constrained. The message of a degenerate window names the weakest.
  /// Empty when the covariance is not known.
  std::vector<WeakDirection> weak_directions;
  WeakDirection weakest() const { return weakestOf(weak_directions); }
  double seconds_coarse = 0, seconds_fine = 0;
  /// solveLidarStereoSearch: the starts solved (1: the guess converged or no search) and the
  /// rotation (camera axes, rad) of the start this result came from.
  int search_starts = 1;
  Eigen::Vector3d search_offset_rad = Eigen::Vector3d::Zero();
  /// The split-window check (LidarStereoSettings::check_window_halves; `tested` false when it
  /// did not run: check off, solve not converged (see halves_when_unsettled), or too few
  /// keyframes).
  struct Halves {
    bool tested = false;
    double chi2 = 0;  ///< (x_a - x_b)^T (P_a + P_b)^-1 (x_a - x_b), 6 DoF
    /// The window's estimate against each half's: max over the halves h of
    /// (x_h - x)^T P_h^-1 (x_h - x), 6 DoF (P_h bounds the difference's covariance, P_h - P, from
    /// above). Large when both halves leave the window's minimum.
    double chi2_window = 0;
    /// Halves solved again from the initial guess after the halves from the estimate disagreed
    /// or left it (HalvesStart::kEstimateThenInitialGuess) against those from the estimate:
    /// halvesStartsApart (0: not solved again).
    double chi2_independent = 0;
    double covariance_scale = 1.0;           ///< applied to the covariances (1: consistent)
    Vector6d difference = Vector6d::Zero();  ///< first half's estimate minus the second's
    double seconds = 0;
    /// The second (newer) half's own estimate and covariance, whether that half's fine stage
    /// settled, and whether it converged with every axis trusted: when the halves disagree
    /// because the extrinsic changed inside the window, the calibration monitor compares this
    /// one.
    Eigen::Isometry3d second_T = Eigen::Isometry3d::Identity();
    Matrix6d second_covariance = Matrix6d::Zero();
    bool second_settled = false;
    bool second_trusted = false;
    /// The second half's weak directions (its `weak_directions`): the monitor leaves those beyond
    /// the trust limits out of its comparison, as it does a settled window's.
    std::vector<WeakDirection> second_weak_directions;
    size_t second_begin = 0;  ///< index in the window of the second half's first keyframe
  } halves;
  std::string message;  ///< why it did not converge, when it did not
};

/// Variance (m^2) of a LiDAR point along the unit normal n (camera frame): eq. lidar_noise
/// projected, range noise along the beam direction, beam-direction noise times the range across it.
double lidarVarianceAlong(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const LidarStereoSettings& settings);

/// 1 / sigma of a point-to-plane residual along the unit normal n between a LiDAR point (beam
/// direction, range) and a stereo point of disparity d: the LiDAR point's variance along n
/// (lidarVarianceAlong) plus the stereo point's, stereo_scale |n . p| / d per px of disparity
/// noise (`disparity_sigma`), p the stereo point as triangulated.
double pointPlaneInvSigma(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const Eigen::Vector3d& stereo_point, double disparity,
                          double stereo_scale, double disparity_sigma,
                          const LidarStereoSettings& settings);

/// Solves T_cam_lidar over the window from `T_init`. Never throws on bad data: an empty window or
/// a scene without structure gives converged = false and a message.
LidarStereoResult solveLidarStereo(const std::vector<const Keyframe*>& window,
                                   const Eigen::Isometry3d& T_init,
                                   const LidarStereoSettings& settings = {});

/// solveLidarStereo from `T_init` and, when that does not converge and
/// `settings.search_step_deg` > 0, from the 8 starts turned by +-step about the camera's x and y
/// axes (LidarStereoSettings::search_step_deg; only one of them with
/// LidarStereoSettings::search_start >= 0). Returns the converged solve with the most fine
/// inliers, refused when another start settled elsewhere and fits the window as well
/// (refuseBesideRivalMinimum), or, when none converged, the solve from `T_init` (its message says
/// how many starts were tried). Each solve checks its divergence bound against its own start, which
/// is at most 1.42 step from `T_init`.
LidarStereoResult solveLidarStereoSearch(const std::vector<const Keyframe*>& window,
                                         const Eigen::Isometry3d& T_init,
                                         const LidarStereoSettings& settings);

/// Whether `result` determines its disparity offset: measured, beyond
/// settings.disparity_offset_significance times its sigma, and that sigma within
/// settings.max_disparity_offset_sigma_px.
bool disparityOffsetMeasured(const LidarStereoResult& result, const LidarStereoSettings& settings);

/// The common disparity offset's sigma the covariance's bias term uses for `result`: the model's
/// (settings.model_sigma_disparity_px), or the offset the residuals show when the window
/// determines it (disparityOffsetMeasured) and it is larger.
double disparityBiasSigma(const LidarStereoResult& result, const LidarStereoSettings& settings);

/// Whether the bias term uses the measured offset instead of the model's (it is larger).
bool disparityOffsetWidensBias(const LidarStereoResult& result,
                               const LidarStereoSettings& settings);

/// Per-axis trust flags (LidarStereoResult::observable) from a covariance over [phi; tau]: an
/// axis is trusted when its sigma is within settings.max_sigma_*; true when every axis is.
bool trustFlags(const Matrix6d& covariance, const LidarStereoSettings& settings,
                bool observable[6]);

/// The split-window check on a solve of `window` (`full`, with the settings it was solved with):
/// solves each half again (fine stage only, from `full`'s estimate, stereo scale and yaw) and
/// compares the two estimates against their summed covariances (a half that did not settle
/// within twice the fine stage's budget still counts: its last updates are far below its sigma).
/// Within the limit the result is unchanged apart from `halves`; beyond it `covariance` and
/// `covariance_statistical` are scaled by chi2 / 6 (`covariance_model`, the paper's formula, is
/// kept), the trust flags are evaluated again, and a solve that loses one is no longer converged.
/// Real KITTI windows fail it (sequences of one day disagree by 3-6 sigma), generated ones pass.
/// With HalvesStart::kEstimateThenInitialGuess (the default), halves that disagree or both leave
/// the estimate are solved again from `T_initial`, the window's initial guess, and a converged
/// solve is refused when a half then settles elsewhere (halvesStartsApart); with
/// kEstimateAndInitialGuess they are solved again from `T_initial` whatever they showed.
void checkWindowHalves(const std::vector<const Keyframe*>& window,
                       const LidarStereoSettings& settings, const Eigen::Isometry3d& T_initial,
                       LidarStereoResult* full);

/// The HalvesStart a name gives: "recheck" (kEstimateThenInitialGuess), "estimate", "initial" or
/// "always" (kEstimateAndInitialGuess); false for any other name.
bool halvesStartFromName(const std::string& name, HalvesStart* start);

/// Whether the split-window check runs on `result`: the check is on and the solve converged or,
/// with LidarStereoSettings::halves_when_unsettled, its fine stage did not settle with enough
/// associations.
bool windowHalvesDue(const LidarStereoResult& result, const LidarStereoSettings& settings);

}  // namespace tescalib
