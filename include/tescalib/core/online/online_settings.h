// Settings of the online calibrator (online_calibrator.h): keyframe spacing and the sliding
// window, which solve runs when (LiDAR-first, co-calibration, joint), and the publish policy's
// bounds (publish_policy.h).
#pragma once

#include <algorithm>
#include <string>

#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/stereo/image_quality.h"

namespace tescalib {

/// The calibration monitor (calibration_monitor.h): a CUSUM over the chi2 of fresh windows'
/// estimates against the published one, per extrinsic.
struct MonitorSettings {
  /// "recalibrate": on `changed` the window restarts from the keyframes after the change and the
  /// next trusted estimate replaces the old one; "flag": the monitor only reports; "off": no
  /// monitoring (every trusted estimate is published, as without a monitor). While `changed` /
  /// `recalibrating` the old extrinsic stays published (and on the node's /tf_static).
  std::string action = "recalibrate";
  /// The CUSUM's reference value: each fresh window adds chi2 - cusum_k to the evidence (never
  /// below 0), at most two thirds of cusum_h (one window alone, however far off, declares
  /// nothing). 22.46 is chi2's 99.9 % quantile with 6 DoF.
  double cusum_k = 22.46;
  /// Evidence at which the extrinsic counts as changed (with change_span_s of driving).
  double cusum_h = 60.0;
  /// s of driving from the first window that raised the evidence (`suspect`) to the one that
  /// declares `changed`.
  double change_span_s = 3.0;
  /// A solve's window counts as fresh evidence when at least this fraction of its keyframes is
  /// newer than every keyframe of the last window counted (non-overlapping windows).
  double fresh_fraction = 0.6;
  /// With co-calibration: once this many keyframes are newer than the left_to_right monitor's
  /// last fresh window, the pair is solved on them alone (pair_check.h) and that is its fresh
  /// window. 0: only the window's solves are evidence.
  int pair_check_keyframes = 4;
  /// The pair check takes its depth from the published LiDAR extrinsic, which may itself have
  /// changed since its last check: its covariance allows a LiDAR change of this size (1 sigma per
  /// axis, through the check's LiDAR sensitivity), so that a LiDAR bump is not taken for a change
  /// of the pair; directions of the pair a LiDAR change does not move keep their precision.
  double pair_check_lidar_change_deg = 0.5;
  double pair_check_lidar_change_m = 0.05;
  /// With action "recalibrate", once a full window's estimate is published: the published
  /// estimate is the mean of the last this many fresh windows that agreed with it
  /// (window_average.h), and solves in between are held. 1: each trusted solve is published.
  int average_windows = 8;
};

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
  /// start 15 deg / 1.5 m off in (the alternation from there runs away in every round and
  /// publishes nothing). Off: nothing is published before the first co-calibration.
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
  /// Co-calibration of both extrinsics; false (the default): LiDAR-stereo only, the stereo
  /// extrinsic as given.
  bool estimate_stereo = false;
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
  /// after a bag's loop replaced one of 10 with rotation errors 2-3x larger.
  double max_variance_growth = 2.0;
  /// The same bound for the first co-calibrated estimate after LiDAR-first ones: their LiDAR
  /// covariance takes camera_info's stereo pair as exact, the co-calibrated one frees the clouds'
  /// scale and yaw, so it is wider by construction (rz variance 2.4-3.3x on generated urban
  /// drives, which max_variance_growth refuses every time).
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
  /// After a solve that did not converge the next one runs the coarse stage (a full alternation)
  /// again: the extrinsic may have moved beyond the fine stage's basin.
  bool warm_start_fine_only = true;
  /// Before the first estimate, a LiDAR-stereo solve (also co-calibration's LiDAR-first one)
  /// that does not converge tries the wide-basin search (LidarStereoSettings::search_step_deg, in
  /// co.lidar) once the window holds min(window_size, search_min_keyframes) keyframes; on fewer a
  /// start turned 10 deg could settle where the few keyframes' constraints allow, and each search
  /// costs 9 solves.
  int search_min_keyframes = 8;
  /// The search's 8 turned starts are spread over the successive solves, one start per solve
  /// (the next solve tries the next start), so that a window that does not converge costs about
  /// two plain solves per keyframe instead of nine; false: every such solve tries all 8.
  bool spread_search = true;
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
  /// With the row check: the pair is re-rectified once for the right camera's pitch and roll that
  /// explain the rows measured (rowAlignedExtrinsic), before the first estimate, and the window
  /// restarts with that keyframe matched again (a real pair's residual rotation after rectification
  /// biases SGBM's disparities of oblique texture; doc/limitations.md). Off: the rows are only
  /// checked.
  bool align_rows = true;
  /// With align_rows: the pair is re-rectified only when that moves some row of the image by more
  /// than this (px): SGBM's disparities do not notice less, and a restart costs a keyframe.
  double align_rows_min_px = 0.05;
  ScanSweep sweep;
  /// Keyframes' mesh and stereo cloud. With `estimate_stereo` the keyframes' clouds take
  /// `co.stereo_cloud`'s refinement instead, so that every cloud of a co-calibration window is of
  /// one kind (co-calibration matches clouds again with it).
  KeyframeSettings keyframe;
  CoCalibrationSettings co;
  MonitorSettings monitor;
};

}  // namespace tescalib
