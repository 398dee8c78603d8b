// The calibration monitor: after the first trusted estimate, each fresh window's estimate of an
// extrinsic is compared with a reference, a published estimate from a window it does not overlap
// (chi2 with both covariances, 6 DoF), and a CUSUM accumulates the excess over
// MonitorSettings::cusum_k (at most two thirds of cusum_h per window) across these
// non-overlapping windows. The reference moves on only to
// the estimate of a fresh window that agreed with it: estimates published in between (each
// solve's window slides by one keyframe) cannot carry it along a change. States per
// extrinsic: calibrating -> calibrated -> suspect (evidence above 0) -> changed (evidence above
// cusum_h, sustained over change_span_s of driving) -> recalibrating (the window restarted from
// the keyframes after the change) -> calibrated (the next published estimate). ROS-free, not
// thread-safe (the calibrator guards it with its lock); tests drive it with synthetic sequences.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/online/online_settings.h"

namespace tescalib {

enum class MonitorState { kCalibrating, kCalibrated, kSuspect, kChanged, kRecalibrating };

/// "calibrating" | "calibrated" | "suspect" | "changed" | "recalibrating".
const char* monitorStateName(MonitorState state);

/// Where one extrinsic's monitor stands.
struct MonitorStatus {
  MonitorState state = MonitorState::kCalibrating;
  double since = 0;       ///< stamp (s) of the window that brought the state
  double evidence = 0;    ///< the CUSUM (chi2 units); cusum_h declares `changed`
  double last_chi2 = -1;  ///< chi2 of the last fresh window counted (-1: none yet)
  int fresh_windows = 0;  ///< fresh windows counted since the first estimate
  int changes = 0;        ///< how often the extrinsic was declared changed
  double changed_at = 0;  ///< stamp of the window that declared the last change
  /// Keyframes newer than this stamp come after the change. Valid once `changed`: the newest
  /// keyframe of the first window that raised the evidence (it may straddle the change), or
  /// later: of a later window of the run whose estimate disagrees with the declaring window's
  /// (it saw the extrinsic before the change), and, when a window's newer half declares, no
  /// keyframe of its older half.
  double change_after = 0;
};

/// One extrinsic's monitor (lidar_to_left or left_to_right).
class ExtrinsicMonitor {
 public:
  explicit ExtrinsicMonitor(const MonitorSettings& settings) : settings_(settings) {}

  /// A solve's estimate `T` (covariance `cov`) from a window with keyframe `stamps`; counted
  /// when the window is fresh (its chi2 against the reference). A covariance that is not finite
  /// is not compared. `newer_half`: the estimate is of a window's newer half (`stamps`), whose
  /// older half disagreed with it. `unconstrained`: directions over [phi; tau] the window does not
  /// constrain (beyond the trust limits, where its covariance is least reliable: a highway's
  /// optical axis); the chi2 leaves them out. Returns true when the state changed.
  bool observe(const std::vector<double>& stamps, const Eigen::Isometry3d& T, const Matrix6d& cov,
               bool newer_half = false, const std::vector<Vector6d>& unconstrained = {});
  /// An estimate `T` (`cov`) from a window whose newest keyframe is `newest` was published. The
  /// first one, and the first after a recalibration, becomes the reference (`calibrated`); later
  /// ones only when they come from the last fresh window counted, which agreed with it. `full`:
  /// the window held its full count of keyframes. Until a full window's estimate is published
  /// the reference is provisional: each published estimate replaces it and no window is
  /// checked (a few keyframes' covariance hardly shows how few they are).
  void published(double newest, const Eigen::Isometry3d& T, const Matrix6d& cov, bool full = true);
  /// The window restarted from the keyframes after the change: `recalibrating`.
  void restarted();
  /// The other extrinsic was declared changed, and this one's evidence was measured through it:
  /// a suspicion is dropped (back to `calibrated`, no evidence); other states stay.
  void dropSuspicion();
  /// The window was cleared with the estimate kept (time went backwards): the next window is
  /// fresh whatever its stamps.
  void forgetStamps() { last_newest_ = -1e300; }
  /// Back to `calibrating` (a reset without estimate).
  void reset() {
    status_ = MonitorStatus();
    last_newest_ = -1e300;
    provisional_ = false;
    run_.clear();
  }

  const MonitorStatus& status() const { return status_; }
  /// Whether a keyframe at `stamp` is new evidence: the extrinsic is checked (calibrated or
  /// suspect, against a full window's reference) and the keyframe is newer than every keyframe
  /// of the last window counted.
  bool isNew(double stamp) const { return checked() && stamp > last_newest_; }
  /// Whether windows are checked: calibrated or suspect (`changed` holds until recalibrated or
  /// reset, and the other states have no estimate to check against), with a full window's
  /// reference.
  bool checked() const {
    return (status_.state == MonitorState::kCalibrated ||
            status_.state == MonitorState::kSuspect) &&
           !provisional_;
  }
  /// The newest keyframe of the last window counted.
  double lastCountedNewest() const { return last_newest_; }
  /// The share of that window's keyframes newer than every keyframe of the window counted
  /// before it.
  double lastFreshShare() const { return last_fresh_share_; }

 private:
  bool setState(MonitorState state, double stamp);
  /// change_after from the windows counted since the evidence last was 0 (MonitorStatus).
  double changeAfter() const;

  /// A fresh window counted: its oldest and newest keyframes and its estimate.
  struct Counted {
    double oldest = 0, newest = 0;
    bool newer_half = false;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    Matrix6d cov = Matrix6d::Zero();
  };

  MonitorSettings settings_;
  MonitorStatus status_;
  double last_newest_ = -1e300;  ///< newest keyframe of the last window counted
  double last_fresh_share_ = 1;  ///< lastFreshShare
  bool provisional_ = false;     ///< the reference is not from a full window yet
  std::vector<Counted> run_;     ///< the windows counted since the evidence last was 0
  Eigen::Isometry3d reference_ = Eigen::Isometry3d::Identity();
  Matrix6d reference_cov_ = Matrix6d::Zero();
};

/// Whether `status` holds a change (`changed` or `recalibrating`).
inline bool holdsChange(const MonitorStatus& status) {
  return status.state == MonitorState::kChanged || status.state == MonitorState::kRecalibrating;
}

/// Both extrinsics' monitors.
struct CalibrationMonitor {
  explicit CalibrationMonitor(const MonitorSettings& settings)
      : lidar_to_left(settings), left_to_right(settings) {}
  ExtrinsicMonitor lidar_to_left, left_to_right;
};

/// A snapshot of both, as the calibrator reports them.
struct MonitorReport {
  MonitorStatus lidar_to_left, left_to_right;
  bool stereo_monitored = false;  ///< left_to_right is estimated (co-calibration)
};

}  // namespace tescalib
