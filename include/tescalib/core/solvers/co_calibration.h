// Co-calibration (paper, "Co-calibration"): alternate the left-right photometric solver and the
// LiDAR-stereo solver, re-rectifying and recomputing the stereo clouds when the left-right
// estimate changed enough to matter, until both estimates are stable.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tescalib/core/solvers/co_calibration_covariance.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/photometric_solver.h"
#include "tescalib/core/solvers/stereo_features.h"
#include "tescalib/core/solvers/window_rectification.h"

namespace tescalib {

/// The stereo clouds co-calibration matches: the keyframes' settings, but one exact disparity
/// refinement round. The LiDAR-stereo default (a smoothed round, then an exact one) removes a
/// disparity bias that co-calibration's stereo scale and yaw absorb anyway; here it measured
/// worse and slower. Without the re-rectified pair's vertical low-pass: co-calibration
/// re-rectifies every pair with its own estimate (a pair on the x axis too), and its figures
/// are measured without it.
inline StereoSettings coStereoCloudSettings(StereoSettings s = {}) {
  s.refinement.iterations = 1;
  s.refinement.smoothed_gradient_rounds = 0;
  s.rectified_vertical_blur_px = 0.0;
  return s;
}

struct CoCalibrationSettings {
  LidarStereoSettings lidar;  ///< its `cancel` also stops the alternation before each round
  PhotometricSettings stereo;
  StereoSettings stereo_cloud = coStereoCloudSettings();  ///< clouds matched again each round
  int max_rounds = 15;
  /// At most this many re-associations of each round's LiDAR-stereo fine stage (less than a
  /// lone solve's LidarStereoSettings::fine_reassociations): the next round starts from this
  /// round's estimate, and a longer fine stage slides further along the valley where the clouds'
  /// yaw and scale and the LiDAR's depth trade before the photometric solve corrects the pair
  /// (with the pair's yaw 0.9 deg off, 20 re-associations run the LiDAR 1.3 m away).
  int round_fine_reassociations = 12;
  /// LidarStereoSettings::fine_stereo_normal_px of the alternation's LiDAR-stereo solves (and of
  /// the joint problem's LiDAR residuals), which replaces `lidar`'s. Here the clouds' scale is
  /// free, and with the faces' normals alone each re-association moves the estimate on along the
  /// valley where that scale and the LiDAR's depth trade (0.4 mm per re-association, every
  /// round the same way, up to 7 cm on some random rigs); the stereo surface's derivative stops
  /// the walk. 0: the faces' normals.
  int fine_stereo_normal_px = 6;
  /// The final LiDAR estimate's split-window check solves the halves again from the initial
  /// guess whatever the halves from the estimate showed (HalvesStart::kEstimateAndInitialGuess,
  /// in place of `lidar.halves_start`'s default kEstimateThenInitialGuess), and refuses an
  /// estimate from which a half then settles elsewhere. Where the clouds' scale and the LiDAR's
  /// depth trade, the rounds can leave the estimate anywhere along that valley, and halves
  /// started from it stay with it: on one generated window two starts ended 5.6 cm apart along
  /// the optical axis, the one 5.7 cm off declared converged with a sigma of 0.9 cm.
  bool halves_always_from_initial_guess = true;
  /// Stability criterion (both must hold for both extrinsics): the last round moved the estimate
  /// by less than this, and so does the remaining distance to the fixed point predicted from the
  /// contraction of the last two rounds (step * rho / (1 - rho), rho = |step_k| / |step_k-1|).
  double stable_rot_deg = 0.01;
  double stable_trans_m = 0.003;
  /// The LiDAR-stereo fine stage counts as settled once its update is below this fraction of the
  /// stability tolerance.
  double inner_settle_fraction = 0.1;
  /// Rounds after the first are warm-started: LiDAR-stereo fine stage only (once a LiDAR-stereo
  /// solve has converged: after a degenerate or unsettled one the coarse stage runs again),
  /// photometric on the finest `warm_pyramid_levels` levels with `warm_iterations` Ceres
  /// iterations per level.
  bool warm_start = true;
  int warm_pyramid_levels = 1;
  int warm_iterations = 10;
  /// Round 1 warm too (no coarse stages): for a start that is already an estimate of this
  /// window's neighbour, as the online calibrator's updates are.
  bool warm_first_round = false;
  /// Stereo clouds are recomputed only when T_right_left's rotation or baseline direction moved
  /// by more than this since they were computed (the baseline length is the stereo scale's job).
  /// 0.005 deg is about 0.06 px of rectification error at KITTI's focal length.
  double rerectify_deg = 0.005;
  /// The same for the baseline direction alone; negative: `rerectify_deg`. A direction error
  /// delta misplaces a match by about disparity x delta (0.07 px at 80 px for 0.05 deg), a
  /// rotation error by f x delta (0.06 px for 0.005 deg).
  double rerectify_direction_deg = 0.05;
  /// The LiDAR-stereo solves estimate the right camera's yaw relative to the clouds'
  /// rectification as a nuisance (LidarStereoSettings::estimate_stereo_yaw): the photometric yaw
  /// of round 1, taken with the LiDAR still degrees off, is 0.1-0.5 deg wrong, and without the
  /// nuisance the LiDAR absorbs that disparity offset along the optical axis and often stays in a
  /// wrong basin with the baseline length.
  bool lidar_estimates_stereo_yaw = true;
  /// When two successive LiDAR-stereo solves find the clouds' yaw more than this far from the
  /// photometric one (the nuisance above) and the gap did not shrink, the photometric yaw sits in
  /// a wrong minimum that later rounds do not leave (a held-out generated start: 0.9 deg off for
  /// 15 rounds, the nuisance saying -0.56, -0.83, -0.88 deg ...; a gap that merely reflects a
  /// LiDAR still far off shrinks: 0.32, 0.27, 0.11 deg). The right camera is then turned to the
  /// LiDAR-stereo yaw and the alternation starts again from there with the initial LiDAR
  /// extrinsic and baseline length, at most `max_yaw_handovers` times. < 0: never.
  double yaw_handover_deg = 0.2;
  int max_yaw_handovers = 2;
  /// Re-rectification tolerance for the right camera's yaw alone when the LiDAR-stereo solve
  /// models it (`lidar_estimates_stereo_yaw`; first order, f yaw (1 + x_r^2) per point).
  double rerectify_yaw_deg = 0.03;
  /// SGBM matches again only beyond these changes from the estimate it last matched with; below
  /// them the clouds are re-triangulated from the last matches (retriangulateStereoCloud), about
  /// 10x cheaper. The yaw does not count (it only shifts the disparity). About camera x and z,
  /// 0.02 deg is a 0.25 px vertical misalignment at KITTI's focal length; a turn of the baseline
  /// by 0.1 deg misaligns a point of disparity d by up to d / 570 vertically (0.1 px at 5 m).
  /// < 0: always match again.
  double rematch_deg = 0.02;
  double rematch_direction_deg = 0.1;
  /// Extrapolates the fixed-point iteration (Aitken's delta-squared on the stacked 12-vector of
  /// both extrinsics) once three successive estimates contract consistently.
  bool extrapolate = true;
  double max_contraction = 0.75;  ///< no extrapolation beyond this rate (jump <= 3 steps)
  /// The photometric solver keeps the baseline length it is given (rotation and direction free):
  /// the length comes from the LiDAR-given stereo scale. Off: round 1 takes the photometric length.
  bool photometric_fixed_length = true;
  /// Until the LiDAR-stereo solve has converged (at most rounds 1..free_depth_rounds), the
  /// photometric solves give each key point's depth a log-scale freedom with this prior
  /// (PhotometricSettings::depth_prior_sigma): while the LiDAR is still far off, its depth pulls
  /// the baseline direction (the forward component trades against the LiDAR's depth offset, and
  /// the alternation then creeps back at about 20 % per round); with free depth the direction is
  /// right from round 1, but the yaw is not (only the LiDAR depth fixes it), and clouds rectified
  /// with a yaw 0.3 deg off can keep the warm LiDAR-stereo solves from moving. A round that
  /// settles with free depth is repeated with the LiDAR depth; the final rounds always use it.
  /// Off by default (0): it is faster on most generated starts, slower on some, and on KITTI one
  /// start in ten runs away.
  int free_depth_rounds = 0;
  double free_depth_prior_sigma = 0.05;
  /// Per-axis model error added to the final covariances (camera axes, 1 sigma): each solve's
  /// covariance is conditional on the other extrinsic being exact, and in the alternation the
  /// stereo baseline length and yaw follow the LiDAR depth. Calibrated like the solvers' own terms,
  /// on generated windows (the held-out check: doc/benchmarks.md); the observability flags do not
  /// use it (they stay the solvers').
  /// The stereo terms are what remains beyond the stereo scale's variance and the LiDAR
  /// covariance propagated through the key points' depth (the rotation needs none). The LiDAR
  /// terms are fitted with the stereo pair's uncertainty propagated (propagate_stereo_into_lidar),
  /// the stereo terms with the pair's covariance taking the LiDAR's given the pair.
  std::array<double, 3> model_sigma_lidar_rot_deg = {0.0119, 0.0, 0.0145};
  std::array<double, 3> model_sigma_lidar_trans_m = {0.0, 0.00079, 0.00141};
  std::array<double, 3> model_sigma_stereo_rot_deg = {0.0003, 0.0006, 0.0};
  std::array<double, 3> model_sigma_stereo_trans_m = {0.000535, 0.000064, 0.000135};
  /// 1-sigma of the clouds' scale beyond its statistical variance (relative; an error of the
  /// pair's f B), for a pair with f B = LidarStereoSettings::model_floor_focal_baseline_px_m and
  /// scaled with that over the window's own f B like the LiDAR-stereo floors: the matcher's
  /// error that no window averages away pulls the scale and the LiDAR's depth along the valley
  /// in which they trade. A scale error k moves the baseline length by B k and the LiDAR
  /// estimate by LidarStereoResult::stereo_scale_sensitivity k; both covariances get it.
  double model_sigma_stereo_scale = 0.002;
  /// The pair's covariance at the alternation's fixed point, as the LiDAR's: G (P_pair|LiDAR +
  /// L P_LiDAR|pair L^T) G^T with G = (I - L S)^-1 (L: the left-right solve's sensitivity to
  /// the LiDAR, S: the LiDAR's to the pair; S measured, propagate_stereo_into_lidar). A deviation
  /// of the pair moves the LiDAR, which moves the pair again; without G the pair's sigma along
  /// the baseline's y and z ignores that loop (0.3-0.7 on generated windows).
  bool stereo_fixed_point_gain = true;
  /// The stereo pair's uncertainty in the LiDAR covariance (an addition to the
  /// paper): the LiDAR-stereo solve estimates the clouds' scale and yaw, but the rest of the pair
  /// (rotation about x and z, the baseline direction in y and z) moves the clouds, and so the
  /// LiDAR estimate, too. Its sensitivity (lidarSensitivityToStereo: central differences of the
  /// fine stage, clouds re-triangulated with the pair perturbed by these steps) carries the
  /// left-right covariance into the LiDAR one, S P S^T, with the fixed point's gain (I - S L)^-1
  /// of the alternation (L: the left-right solve's sensitivity to the LiDAR). On one of the co
  /// benchmark's six windows the pair's error holds the LiDAR 3 sigma off about the optical axis.
  bool propagate_stereo_into_lidar = true;
  /// A warm update (one round, OnlineSettings::warm_co_rounds, which cannot be called stable)
  /// propagates the pair's uncertainty with this sensitivity of an earlier full run's
  /// (`lidar_stereo_sensitivity`) instead of none: without it the online node compared and
  /// published a LiDAR covariance without the pair's uncertainty against one with it (rz sigma
  /// 42 % smaller after one more keyframe). Used only when the run is not
  /// stable; a stable run computes its own.
  bool reuse_lidar_sensitivity = false;
  Matrix6d lidar_sensitivity_to_stereo = Matrix6d::Zero();
  double sensitivity_step_rot_deg = 0.01;
  double sensitivity_step_trans_m = 0.002;
  /// Second opinion (secondOpinion) on a converged LiDAR estimate at least `confirm_beyond_deg`
  /// or `confirm_beyond_m` from the initial guess (a negative limit is not used; both negative:
  /// never asked; the yaw of the clouds starts where the last solve left it): LiDAR-stereo is
  /// solved once more, coarse and fine, from the initial guess with the final clouds; when that
  /// converges further than `confirm_disagree_deg` / `confirm_disagree_m` from the estimate, the
  /// window has two minima and the result is not converged. Without it, a start 3 deg / 0.3 m off
  /// whose first rounds rectify with the baseline direction 11 deg off settles 2.1 m off along
  /// the optical axis, declared converged (doc/limitations.md).
  double confirm_beyond_deg = 5.0;
  double confirm_beyond_m = 0.5;
  double confirm_disagree_deg = 0.5;
  double confirm_disagree_m = 0.05;
  /// LiDAR first (option, off by default), once, before any LiDAR-stereo solve of the
  /// alternation has converged: when a photometric solve is not photo-consistent or diverged (the
  /// key points' LiDAR depth too far off), or when a LiDAR-stereo estimate ran away from the
  /// initial guess, LiDAR-stereo is tried from the initial guess with the wide-basin search
  /// (LidarStereoSettings::search_step_deg): after a failed photometric solve on clouds rectified
  /// with its rotation (unless it diverged) and the baseline from before, after a runaway on the
  /// round's clouds. It is taken only when it converged within the divergence bounds; otherwise
  /// the round goes on as without it. From the LiDAR
  /// 10 deg / 1 m and the stereo pair 0.1 deg / 1 cm off, 5 of 12 generated starts instead of 4;
  /// on the 30 benchmark starts the same results, but it ran (and was not taken) on 14 of them,
  /// 2-14 s each.
  bool lidar_first_fallback = false;
  /// Stereo from features first (stereo_features.h; an addition to the paper): round 1 takes
  /// the pair's rotation and baseline direction from left-right feature matches (the length
  /// stays the guess'), which need no depth, instead of a photometric solve on the initial LiDAR
  /// extrinsic's depth, and solves LiDAR-stereo on clouds rectified with them with the wide-basin
  /// search (LidarStereoSettings::search_step_deg); the photometric solves start in round 2, on
  /// that LiDAR estimate's depth. When the matches do not give an estimate
  /// (FeatureStereoResult::ok), round 1 is the photometric one as without it. Generated
  /// urban, window 10: from the LiDAR 10 deg / 1 m and the
  /// stereo pair 1 deg / 0.1 m off 96.7 % of 30 starts (30 % without); from 3 deg / 0.3 m 100 %
  /// of the 30 benchmark and the 54 held-out starts as without it, in about half the time.
  bool stereo_from_features = true;
  FeatureStereoSettings features;
};

struct CoCalibrationResult {
  LidarStereoResult lidar;  ///< last LiDAR-stereo solve (T_cam_lidar, covariance, ...)
  /// Last left-right solve (T_right_left, covariance, ...). Its covariance includes the baseline
  /// length's variance from the stereo scale and, through `lidar_sensitivity` (here without its
  /// length component), the final LiDAR covariance, besides the model error below.
  PhotometricResult stereo;
  int rounds = 0;
  int rectifications = 0;        ///< rounds in which stereo clouds were recomputed
  int rematches = 0;             ///< keyframe clouds matched again (SGBM), not re-triangulated
  int extrapolations = 0;        ///< Aitken steps taken
  int rejected = 0;              ///< rounds whose LiDAR-stereo estimate ran away (not taken)
  int yaw_handovers = 0;         ///< restarts with the right camera at the LiDAR's yaw
  bool lidar_first = false;      ///< the LiDAR-first fallback ran (lidar_first_fallback)
  FeatureStereoResult features;  ///< stereo_from_features: the estimate from the matches
  /// propagate_stereo_into_lidar: d T_cam_lidar / d T_right_left (perturb() convention on both
  /// sides; the columns of the clouds' yaw and of the length, which the LiDAR-stereo solve
  /// estimates itself, are zero), and the spectral radius of its product with the left-right
  /// solve's sensitivity to the LiDAR (the alternation's contraction; below 1 at a fixed point).
  Matrix6d lidar_stereo_sensitivity = Matrix6d::Zero();
  double coupling = 0;
  /// `lidar.covariance` as it would be with the left-right pair taken as exact (before the
  /// propagation above; with the model error): what a LiDAR-first estimate's covariance is, so
  /// the two can be compared like with like (OnlineCalibrator's first co-calibrated estimate).
  Matrix6d lidar_covariance_given_stereo = Matrix6d::Identity();
  bool stable = false;              ///< the stability criterion was met within max_rounds
  bool converged = false;           ///< stable and both solvers converged
  double seconds_stereo_cloud = 0;  ///< time spent recomputing stereo clouds
  double seconds_photometric = 0, seconds_lidar = 0;
  double seconds = 0;
  std::string message;
};

/// CoCalibrationSettings::confirm_*: empty when the converged LiDAR-stereo estimate `lidar` (of
/// `window`'s current clouds, solved with `settings`) is within both confirm_beyond_* limits of
/// `T_cam_lidar_init` or a solve from `T_cam_lidar_init` with the same clouds either does not
/// converge or lands within the confirm_disagree_* limits of it; otherwise why it is not trusted
/// (also when `settings.cancel` stopped that solve).
/// `seconds` (optional) receives the time of that solve.
std::string secondOpinion(const std::vector<const Keyframe*>& window,
                          const Eigen::Isometry3d& T_cam_lidar_init, const LidarStereoResult& lidar,
                          const LidarStereoSettings& settings, const CoCalibrationSettings& s,
                          double* seconds = nullptr);

/// The tolerances of `settings` (rerectify_*, rematch_*; the yaw only with the yaw nuisance).
RectifyTolerances rectifyTolerances(const CoCalibrationSettings& settings);

/// The LiDAR-stereo settings of a co-calibration's solves: `settings.lidar` with the clouds'
/// disparity noise, the stereo scale free and the clouds' yaw as a nuisance (when
/// `lidar_estimates_stereo_yaw`).
LidarStereoSettings coLidarStereoSettings(const CoCalibrationSettings& settings);

/// The left-right settings of a co-calibration's photometric solves: `settings.stereo` with the
/// baseline length kept (`photometric_fixed_length`) and, `warm`, only the finest
/// `warm_pyramid_levels` levels with `warm_iterations` iterations each.
PhotometricSettings coPhotometricSettings(const CoCalibrationSettings& settings, bool warm);

/// Runs the alternation over `window` (stereo clouds are recomputed in place). The stereo solver
/// goes first: it tolerates a bad LiDAR extrinsic (paper, "Sensitivity Analysis").
CoCalibrationResult coCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const Eigen::Isometry3d& T_cam_lidar_init,
                                const Eigen::Isometry3d& T_right_left_init,
                                const CoCalibrationSettings& settings = {});

}  // namespace tescalib
