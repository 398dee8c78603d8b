// The online calibrator's solve of its window: LiDAR-stereo alone (the stereo pair kept), or
// co-calibration (the alternation, or the joint solve) once it is due, cold or as warm rounds from
// a co-calibrated estimate. Its result goes to the publish policy (publish_policy.h).
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/online/online_estimate.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/core/online/pair_check.h"
#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

/// Whether a window of `fill` keyframes is co-calibrated. LiDAR first: co-calibration once a
/// LiDAR-stereo estimate is published (or, failing that, once the window is full or no more
/// keyframes will come), so that a start too far off for the alternation gets the LiDAR-stereo
/// solves' wide-basin search first.
bool coCalibrationDue(const OnlineSettings& settings, int fill, bool estimate_published,
                      bool recording_ended);

/// What a solve starts from, read from the calibrator in one go.
struct WindowSolveInput {
  /// The window's keyframes; deep copies for co-calibration, which recomputes their stereo
  /// clouds in place.
  std::vector<std::shared_ptr<Keyframe>> keyframes;
  bool co = false;  ///< coCalibrationDue
  /// The published estimate's extrinsics, or the initial ones.
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  std::optional<OnlineEstimate> published;
  /// The published full co-calibration's LiDAR sensitivity to the pair, for the warm updates
  /// after it (CoCalibrationSettings::reuse_lidar_sensitivity).
  std::optional<Matrix6d> lidar_sensitivity;
  /// The search start this solve tries when its guess does not converge
  /// (OnlineSettings::spread_search; LidarStereoSettings::search_start).
  int search_start = 0;
  /// The calibrator's last solve converged (or there was none). A warm start from the published
  /// estimate skips the coarse stage (OnlineSettings::warm_start_fine_only) only then: after a
  /// failure, an extrinsic that changed by more than the fine stage's basin among the causes,
  /// the coarse stage brings the start in.
  bool last_converged = true;
  /// An extrinsic is recalibrating (MonitorState::kRecalibrating): the published estimate is of
  /// the rig before the change, so a co-calibration runs in full, not as warm rounds from it.
  bool recalibrating = false;
  /// The newest keyframes, for a pair check (pair_check.h) after the solve; empty: none due.
  std::vector<std::shared_ptr<const Keyframe>> pair_check;
};

/// The newer half of a window whose two halves disagreed (LidarStereoResult::Halves), solved on
/// its own until its fine stage settled: what the calibration monitor compares when the
/// extrinsic changed inside the window, which then does not converge as a whole. Its axes need
/// not all be trusted: the monitor's chi2 weighs each direction by its covariance, so a weak
/// direction adds little evidence either way.
struct NewerHalfEstimate {
  std::vector<double> stamps;  ///< its keyframes' stamps
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();
  /// Its directions beyond the trust limits (over [phi; tau]): what the half does not constrain,
  /// left out of the monitor's comparison.
  std::vector<Vector6d> unconstrained;
};

struct WindowSolveResult {
  /// The solve's estimate; keyframes_used, stamp, solve_seconds, solve_id and chi2_to_published
  /// are the caller's to fill.
  OnlineEstimate estimate;
  /// Per keyframe of the input, the LiDAR-stereo information (KeyframeWindow::storeInformation).
  std::vector<Matrix6d> keyframe_information;
  /// A stable full co-calibration's LiDAR sensitivity to the pair (the next input's, once this
  /// estimate is published).
  std::optional<Matrix6d> lidar_sensitivity;
  /// A LiDAR-stereo window that settled and whose halves agree, not converged only because some
  /// axis is not constrained (LidarStereoResult::only_unconstrained): its estimate is evidence
  /// for the calibration monitor, whose chi2 weighs each direction by the covariance, except
  /// the directions beyond the trust limits (`unconstrained_lidar`, over [phi; tau]), which it
  /// leaves out: where the scene does not constrain the rig the covariance is least reliable.
  bool settled_unconstrained = false;
  std::vector<Vector6d> unconstrained_lidar;
  /// A co-calibration whose left-right solve converged with a known covariance, whatever its
  /// LiDAR-stereo solve did: its T_right_left is evidence for the calibration monitor even when
  /// a changed pair leaves the LiDAR-stereo solve unsettled (the clouds are rectified for the
  /// old pair, and the halves of a window that straddles the change disagree).
  bool stereo_settled = false;
  /// A co-calibration whose LiDAR-stereo halves disagreed (LidarStereoResult::Halves): with a
  /// changed pair the newer half's clouds are rectified for the old pair, while a window that
  /// keeps its keyframes by information can hold mostly keyframes from before the change, whose
  /// left-right estimate does not show it. The calibrator then keeps the newest keyframes.
  bool co_halves_disagree = false;
  /// The input keyframes' stereo clouds were recomputed (co-calibration): the window takes them
  /// when the estimate is published (KeyframeWindow::adoptRecomputedClouds).
  bool clouds_recomputed = false;
  /// The solver itself saw the cancel: coCalibrate, jointCalibrate and solveLidarStereo(Search)
  /// all end with the message "cancelled" when the flag is up at their end.
  bool solver_cancelled = false;
  std::string message;  ///< the solver's (empty for a converged warm co-calibration update)
  /// The search ran (the guess did not converge): the next solve tries the next start.
  bool searched = false;
  /// Set when the LiDAR-stereo solve's halves disagreed and the newer one is trusted.
  std::optional<NewerHalfEstimate> newer_half;
  /// The pair check of the input's `pair_check` keyframes, when it converged.
  std::optional<PairCheck> pair_check;
};

/// The newer half of `result`'s window (`keyframes`, the solve's window) when its halves disagreed
/// and that half settled: the calibration monitor's evidence of a change inside the window.
std::optional<NewerHalfEstimate> newerHalf(const LidarStereoResult& result,
                                           const LidarStereoSettings& settings,
                                           const std::vector<std::shared_ptr<Keyframe>>& keyframes);

/// Solves the window. Throws what the solvers throw (a DataError on an estimate gone far off,
/// OpenCV on data it cannot use). `cancel` stops the solvers (LidarStereoSettings::cancel).
WindowSolveResult solveWindow(const WindowSolveInput& input, const StereoRig& rig,
                              const OnlineSettings& settings, const std::atomic<bool>* cancel);

}  // namespace tescalib
