// The online calibration state machine, ROS-free: keyframe selection (>= min_dt apart), a
// sliding window of preprocessed keyframes, co-calibration on demand, and the rule that a new
// estimate only replaces the published one when it is at least as trustworthy. The nodelet feeds
// it frames and publishes what it returns; tests drive it directly.
#pragma once

#include <algorithm>
#include <atomic>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "tescalib/core/common/types.h"
#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

struct OnlineSettings {
  double keyframe_min_dt = 0.5;  ///< s between keyframes
  int window_size = 10;          ///< keyframes in the sliding window (paper's co-calibration: 10)
  int min_keyframes = 3;         ///< solve only with at least this many
  /// With co-calibration at least this many: on 3 keyframes the first alternation often ran all
  /// its rounds without settling (7 s on the demo drive), delaying the first estimate.
  int min_keyframes_co = 5;
  /// With co-calibration: until the window holds `min_keyframes_co` keyframes, solve LiDAR-stereo
  /// only (T_right_left kept at its initial value, published as not estimated), so the first
  /// T_cam_lidar comes as early as without co-calibration and the first alternation starts from
  /// it. Co-calibration starts only once such a LiDAR estimate is published or the window is full:
  /// until then LiDAR-stereo solves, with their wide-basin search (search_min_keyframes), bring a
  /// start 15 deg / 1.5 m off in (the alternation from there ran away in every round and
  /// published nothing). Off: nothing is published before the first co-calibration.
  bool lidar_first = true;
  /// Whether a frame at `stamp` is too close after the keyframe at `last_keyframe_stamp` to be
  /// one (the one spacing rule of the calibrator and of the callers' cheap pre-selection).
  bool tooClose(double stamp, double last_keyframe_stamp) const {
    return stamp - last_keyframe_stamp < keyframe_min_dt - 1e-3;
  }
  int minKeyframes() const {
    return estimate_stereo && !lidar_first ? std::max(min_keyframes, min_keyframes_co)
                                           : min_keyframes;
  }
  bool estimate_stereo = true;  ///< co-calibration; false: LiDAR-stereo only, stereo fixed
  /// With estimate_stereo: co-calibrate with jointCalibrate (both residual sets in one Ceres
  /// problem, joint_calibration.h) instead of the alternation. Its keyframes' meshes fit every
  /// face's normal (LidarMeshSettings::sampled_faces = 0), which the joint problem needs. An
  /// update from a published estimate starts from it with one photometric-first round (no
  /// feature matches, no wide-basin search; from a co-calibrated estimate with
  /// warm_start_fine_only its LiDAR-stereo solve runs the fine stage alone) instead of the
  /// alternation's warm rounds (warm_co_rounds does not apply), and its LiDAR covariance takes the
  /// pair as exact (cov_lidar = cov_lidar_given_stereo, as the joint covariance solve does).
  bool joint = false;
  double max_sync_skew = 0.05;      ///< s; LiDAR and image stamps further apart are rejected
  double max_time_jump_back = 0.0;  ///< s; a stamp earlier than the last by more resets the window
  /// A new estimate replaces the current one only when converged and no axis's variance is more
  /// than this factor times the current one's (never publish something less trustworthy). Per
  /// axis, since a trace adds rad^2 to m^2: rotation was 0.5 % of it, so a window of 3 keyframes
  /// after a bag's loop replaced one of 10 with rotation errors 2-3x larger (session 22 audit).
  double max_variance_growth = 2.0;
  /// The same bound for the first co-calibrated estimate after LiDAR-first ones: their LiDAR
  /// covariance takes camera_info's stereo pair as exact, the co-calibrated one frees the clouds'
  /// scale and yaw, so it is wider by construction (session 23: rz variance 2.4-3.3x on
  /// generated urban drives, which max_variance_growth refused every time).
  double max_variance_growth_first_co = 10.0;
  /// A converged solve that is not published is compared with the published estimate: e^T (P_new
  /// + P_published)^-1 e of their T_cam_lidar difference (6 DoF; the two covariances taken as
  /// independent, though their windows may share keyframes, which makes it smaller, not larger).
  /// Beyond this value (the 99.9 % quantile of chi2 with 6 DoF) the message says that the
  /// extrinsic may have changed since (the published estimate is kept; ~reset recalibrates).
  double changed_chi2 = 22.46;
  /// A keyframe whose stereo cloud has fewer points is rejected (a black or noise right image:
  /// generated and KITTI keyframes have 7600-14000 at full size, a black right image 0).
  int min_stereo_points = 200;
  /// A keyframe whose pair fails these (pairQualityProblem: contrast, one image much more black
  /// or saturated than the other, one camera blurred) is rejected with the measured value, before
  /// its stereo cloud is computed: generated urban keyframes with the right image blurred by 1 px
  /// gave a LiDAR-stereo estimate 1.6 cm off (declared not converged, but without saying why).
  ImageQualitySettings image_quality;
  /// Once an estimate is published, solve from it with the LiDAR-stereo fine stage alone. The
  /// coarse stage exists to bring a start degrees / decimetres off into the fine stage's basin;
  /// from a converged estimate it only costs time (70-80 % of a 10-keyframe solve). With
  /// co-calibration it also makes the updates after a co-calibrated estimate warm rounds
  /// (warm_co_rounds); false: a full alternation each time (several s instead of about 1 s).
  bool warm_start_fine_only = true;
  /// Before the first estimate, a LiDAR-stereo solve (also co-calibration's LiDAR-first one)
  /// that does not converge tries the wide-basin search (LidarStereoSettings::search_step_deg, in
  /// co.lidar) once the window holds min(window_size, search_min_keyframes) keyframes; on fewer a
  /// start turned 10 deg could settle where the few keyframes' constraints allow, and each search
  /// costs 9 solves.
  int search_min_keyframes = 8;
  /// Co-calibration: once an estimate is published, an update runs this many warm rounds
  /// (photometric on the finest level, LiDAR-stereo fine stage) from it instead of the full
  /// alternation: the alternation continues across updates, so such an update is published when
  /// both solves converged (and the trace rule holds), without the stability criterion of a
  /// full run. Re-rectified stereo clouds are kept in the window.
  int warm_co_rounds = 1;
  /// Which keyframe leaves a full window: "information" drops the one whose loss costs least in
  /// the window's weakest direction (from the last solve's per-keyframe LiDAR-stereo information),
  /// so that keyframes adding nothing there (a highway after a town) do not push out the ones that
  /// constrain it (paper: reject bad driving scenarios); "fifo" drops the oldest.
  std::string keyframe_selection = "information";
  /// Motion-compensate each keyframe's scan to the camera trigger (scan_motion.h): its velocity
  /// comes from registering it to the previous scan, which must be at most `deskew_max_dt` older
  /// (at 12 m/s a raw scan's points at the edges of the camera view are 14 cm off). Off for
  /// scans the driver already compensated (KITTI odometry) or that are taken at one instant.
  bool deskew = false;
  double deskew_max_dt = 0.25;  ///< s
  /// The first keyframe's pair (the first with at least 100 corners followed) is checked against
  /// the stereo calibration (verticalAlignment):
  /// when the right image's rows lie more than this (median, px) from where it puts them, addFrame
  /// returns the keyframe with a message saying so (SGBM matches along rows, so its clouds are
  /// biased; a wrong camera_info is the usual cause). <= 0: no check. KITTI: 0.01-0.13 px.
  double max_row_offset_px = 0.5;
  ScanSweep sweep;
  /// Keyframes' mesh and stereo cloud. With `estimate_stereo` the keyframes' clouds take
  /// `co.stereo_cloud`'s refinement instead, so that every cloud of a co-calibration window is of
  /// one kind (co-calibration matches clouds again with it).
  KeyframeSettings keyframe;
  CoCalibrationSettings co;
};

/// What the calibrator currently believes.
struct OnlineEstimate {
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  Matrix6d cov_lidar = Matrix6d::Identity();
  Matrix6d cov_stereo = Matrix6d::Identity();
  /// cov_lidar with the left-right pair taken as exact (a LiDAR-first estimate's cov_lidar; a
  /// co-calibrated one's before the pair's uncertainty was propagated into it).
  Matrix6d cov_lidar_given_stereo = Matrix6d::Identity();
  /// false: the solve ended before computing that covariance (a ~candidate whose LiDAR-stereo or
  /// left-right solve stopped early); cov_* then hold placeholders, not uncertainties.
  bool cov_lidar_known = true, cov_stereo_known = true;
  bool observable_lidar[6] = {false, false, false, false, false, false};
  bool observable_stereo[6] = {false, false, false, false, false, false};
  /// The LiDAR-stereo solve's weakest direction (LidarStereoResult::weakest: what the window
  /// constrains, in units of the trust limits).
  WeakDirection weakest_lidar;
  /// The same for T_right_left (the left-right solve's; ratio 0 when it is not estimated).
  WeakDirection weakest_stereo;
  bool converged = false;
  int keyframes_used = 0;
  double cost_lidar = 0, cost_stereo = 0;
  int iterations_lidar = 0, iterations_stereo = 0;
  int co_rounds = 0;  ///< co-calibration rounds of the solve (0: LiDAR-stereo only)
  /// T_right_left comes from a co-calibration (false: the initial one, cov_stereo zero).
  bool stereo_estimated = false;
  double stamp = 0;  ///< stamp of the newest keyframe of the window it came from
  double solve_seconds = 0;
  /// Numbers the solves whose result was kept (lastSolve), from 1: a caller publishing every
  /// solve's result tells a new one from the one before (a discarded solve keeps the old).
  uint64_t solve_id = 0;
  /// OnlineCalibrator::lastSolve: why the solve was not published (empty when it was).
  std::string message;
  /// e^T (P + P_published)^-1 e of this T_cam_lidar against the estimate published before the
  /// solve (OnlineSettings::changed_chi2); NaN when there was none or the solve did not converge.
  double chi2_to_published = std::numeric_limits<double>::quiet_NaN();
};

enum class FrameResult { kKeyframe, kTooClose, kReset, kRejected };

class OnlineCalibrator {
 public:
  /// `rig` holds the intrinsics and the initial extrinsics.
  OnlineCalibrator(const StereoRig& rig, const OnlineSettings& settings);

  /// Keyframe selection and preprocessing (mesh, stereo cloud). Thread-safe. `message` explains
  /// a rejection or a reset. `lidar_stamp` is the scan's stamp (checked against the frame's).
  /// `built` (optional) receives the keyframe on kKeyframe (read-only: the window shares it).
  /// A kKeyframe comes with an empty message, or with a warning about the pair (its rows, see
  /// OnlineSettings::max_row_offset_px).
  FrameResult addFrame(const Frame& frame, double lidar_stamp, std::string* message,
                       std::shared_ptr<const Keyframe>* built = nullptr);

  /// With OnlineSettings::deskew: the scan the next frame's motion is registered to, when the
  /// caller passes only keyframe candidates to addFrame (addFrame itself keeps each frame's scan).
  void setPreviousScan(std::shared_ptr<const LidarScan> scan, double stamp);

  /// Runs co-calibration on a snapshot of the window. Returns true when the published estimate
  /// changed; `published` then receives it (read under the same lock, so a reset right after
  /// cannot leave the caller without it). Thread-safe; the window keeps filling while it runs.
  /// A solve during which the window was cleared (reset(), or time going backwards) discards
  /// its result: it belongs to data that are gone, and a reset must not bring back the estimate
  /// it cleared.
  /// `recording_ended`: no more keyframes will come (an offline tool at the end of its input),
  /// so with co-calibration the window counts as full for the LiDAR-first rule: a recording
  /// shorter than the window whose LiDAR-stereo solves were never trusted is co-calibrated once
  /// instead of ending without a co-calibration (see coCalibrationPending).
  bool solve(std::string* message, OnlineEstimate* published = nullptr,
             bool recording_ended = false);

  /// With co-calibration: the window holds enough keyframes for it, and the last solve on it was
  /// not one (LiDAR-first, because no estimate was published and the window never filled).
  /// A caller at the end of its input then solves once more with `recording_ended`.
  bool coCalibrationPending() const;

  /// Clears the window and returns to the initial extrinsics.
  void reset();

  /// A sensor stamp seen by the caller before its frame reaches addFrame (a node's callback):
  /// when time went backwards (a looping bag), a solve running now discards its result at once,
  /// instead of publishing the old loop's estimate after the clock has jumped back. The window
  /// itself is cleared by addFrame, as before.
  void noteStamp(double stamp);

  /// Makes a running solve stop at its next re-association, search start or co-calibration
  /// round (within about a second) and every later one return at once, unpublished: for a node
  /// shutting down. Irreversible. A solve it stopped says "cancelled"; one that had ended before
  /// the solver saw the flag says "cancelled after the solve had ended".
  void cancel() { cancel_ = true; }

  std::optional<OnlineEstimate> estimate() const;  ///< the current published estimate
  /// The last solve's result, published or not: `converged` and `message` say which and why.
  /// What the window gives when nothing is trusted (a user's first question on their data);
  /// never the published estimate unless it was published. Cleared by reset() and when time
  /// goes backwards (it described the window then cleared).
  std::optional<OnlineEstimate> lastSolve() const;
  size_t windowFill() const;
  bool readyToSolve() const;
  const StereoRig& rig() const { return rig_; }
  Eigen::Isometry3d currentTcamLidar() const;  ///< estimate, or the initial guess
  Eigen::Isometry3d currentTrightLeft() const;
  /// Stamps of the keyframes in the window, oldest first.
  std::vector<double> windowStamps() const;

 private:
  StereoRig rig_;  ///< intrinsics + initial extrinsics
  OnlineSettings settings_;
  mutable std::mutex mutex_;
  std::deque<std::shared_ptr<Keyframe>> window_;  ///< GUARDED_BY(mutex_)
  std::optional<OnlineEstimate> estimate_;        ///< GUARDED_BY(mutex_)
  std::optional<OnlineEstimate> last_solve_;      ///< GUARDED_BY(mutex_)
  double last_stamp_ = -1e300;                    ///< GUARDED_BY(mutex_)
  double last_keyframe_stamp_ = -1e300;           ///< GUARDED_BY(mutex_)
  int new_keyframes_ = 0;                         ///< GUARDED_BY(mutex_) since the last solve
  /// GUARDED_BY(mutex_): counts window clears (reset, time going backwards, also as soon as
  /// noteStamp sees it); a solve that sees it change between its snapshot and its result
  /// discards the result.
  uint64_t generation_ = 0;
  uint64_t solves_kept_ = 0;  ///< GUARDED_BY(mutex_), OnlineEstimate::solve_id
  std::atomic<bool> cancel_{false};
  /// The last frame's scan, for the next keyframe's de-skewing (OnlineSettings::deskew).
  std::shared_ptr<const LidarScan> previous_scan_;  ///< GUARDED_BY(mutex_)
  double previous_scan_stamp_ = -1e300;             ///< GUARDED_BY(mutex_)
  bool rows_checked_ = false;  ///< GUARDED_BY(mutex_) OnlineSettings::max_row_offset_px done
  /// GUARDED_BY(mutex_): the published full co-calibration's LiDAR sensitivity to the pair, for
  /// the warm updates after it (CoCalibrationSettings::reuse_lidar_sensitivity).
  std::optional<Matrix6d> co_sensitivity_;
  /// Per-keyframe LiDAR-stereo information from the last solve that used it, by stamp.
  std::map<double, Matrix6d> keyframe_information_;  ///< GUARDED_BY(mutex_)
  /// Index in window_ of the keyframe to drop when the window is over-full.
  size_t keyframeToDrop() const;  ///< REQUIRES(mutex_)
};

}  // namespace tescalib
