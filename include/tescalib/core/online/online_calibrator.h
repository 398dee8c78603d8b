// The online calibration state machine, ROS-free: keyframe selection (>= min_dt apart) and
// intake (keyframe_intake.h), a sliding window of preprocessed keyframes (keyframe_window.h),
// co-calibration on demand (window_solve.h), and the rule that a new estimate only replaces the
// published one when it is at least as trustworthy (publish_policy.h). The nodelet feeds it frames
// and publishes what it returns; tests drive it directly.
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
#include "tescalib/core/online/calibration_monitor.h"
#include "tescalib/core/online/keyframe_intake.h"
#include "tescalib/core/online/keyframe_window.h"
#include "tescalib/core/online/online_estimate.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/core/online/window_average.h"
#include "tescalib/core/online/window_solve.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

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
  /// The rig: intrinsics and the initial extrinsics (the pair's as re-rectified by
  /// stereo/align_rows); a copy, as the keyframe thread may re-rectify it.
  StereoRig rig() const;
  Eigen::Isometry3d currentTcamLidar() const;  ///< estimate, or the initial guess
  Eigen::Isometry3d currentTrightLeft() const;
  /// Stamps of the keyframes in the window, oldest first.
  std::vector<double> windowStamps() const;
  /// The keyframes in the window stamped at or before `up_to` (an estimate's stamp: those of its
  /// solve still in the window), oldest first; shared and never modified, so a caller may read
  /// them while the window slides on.
  std::vector<std::shared_ptr<const Keyframe>> windowKeyframes(
      double up_to = std::numeric_limits<double>::infinity()) const;
  /// The calibration monitor's state per extrinsic (calibration_monitor.h).
  MonitorReport monitorReport() const;

 private:
  /// A frame selected as a keyframe: what it is built with, and what undoes the selection.
  struct Selection {
    KeyframeInputs inputs;
    double previous_keyframe_stamp = -1e300;  ///< restored when the keyframe is not taken
    uint64_t generation = 0;  ///< a window cleared while the keyframe is built does not get it
  };
  /// Keyframe selection: clears the window when time went backwards, keeps the scan for the next
  /// frame's de-skewing, and selects the frame when it is keyframe_min_dt after the last
  /// keyframe. Returns the frame's result unless it is selected.
  std::optional<FrameResult> selectFrame(const Frame& frame, std::string* msg,
                                         Selection* selection);
  /// A frame selected but then not taken: the next one is judged against the last keyframe
  /// taken, not against this one.
  FrameResult rejectAfterSelection(double stamp, double previous_keyframe_stamp);
  /// The row check of OnlineSettings::max_row_offset_px on the first keyframe with texture
  /// enough; a warning goes to `msg`. Returns whether this keyframe took the check; `realigned`:
  /// whether the pair was re-rectified for it (alignRowsOnce).
  bool checkRowsOnce(const Keyframe& keyframe, std::string* msg, bool* realigned);
  /// OnlineSettings::align_rows: before the first estimate, once, the rig's T_right_left turned
  /// to explain `rows` (measured on `keyframe`) and the window cleared; said in `msg`. Returns
  /// whether it turned.
  bool alignRowsOnce(const Keyframe& keyframe, const VerticalAlignment& rows, std::string* msg);
  /// The keyframe of `frame` built again with the re-rectified pair, for the window the
  /// re-rectification started; null (and why in `msg`) when it is not usable.
  std::shared_ptr<Keyframe> rebuildRealigned(const Frame& frame, double lidar_stamp,
                                             Selection* selection, std::string* msg);
  /// Puts a built keyframe into the window, unless the window was cleared meanwhile.
  FrameResult admitKeyframe(std::shared_ptr<Keyframe> keyframe, uint64_t generation,
                            bool took_row_check, std::shared_ptr<const Keyframe>* built,
                            std::string* msg);
  /// Empties the window and what describes it, and counts the clear.
  void clearWindow();  ///< REQUIRES(mutex_)
  /// The solve's input from the window and the published estimate; false (with `msg`) when the
  /// window holds too few keyframes.
  bool startSolve(bool recording_ended, WindowSolveInput* input, StereoRig* rig,
                  uint64_t* generation, std::string* msg);
  /// Feeds a solve's estimates to the monitors (observeLidar, observePair; neither while the
  /// other extrinsic holds a change); returns why the monitor holds it back
  /// (empty: it does not), restarts the window on `changed` with MonitorSettings::action
  /// recalibrate, and keeps the window oldest-first while either extrinsic is suspect.
  std::string monitorSolve(const WindowSolveInput& input,
                           const WindowSolveResult& result);  ///< REQUIRES(mutex_)
  /// Whether an extrinsic is recalibrating (MonitorState::kRecalibrating).
  bool recalibrating() const;  ///< REQUIRES(mutex_)
  /// A solve's evidence for the lidar_to_left monitor (monitorSolve).
  void observeLidar(const WindowSolveInput& input,
                    const WindowSolveResult& result);  ///< REQUIRES(mutex_)
  /// A solve's evidence for the left_to_right monitor: its pair check, then its window's
  /// left-right estimate (monitorSolve).
  void observePair(const WindowSolveInput& input,
                   const WindowSolveResult& result);  ///< REQUIRES(mutex_)
  /// The keyframes due for a pair check (pair_check.h): those of `recent_` new to the
  /// left_to_right monitor, when they are MonitorSettings::pair_check_keyframes or more and a
  /// co-calibrated pair is published; else none.
  std::vector<std::shared_ptr<const Keyframe>> pairCheckKeyframes() const;  ///< REQUIRES(mutex_)
  /// Where the lidar_to_left monitor stood before a solve was observed (averageOrHold).
  struct BeforeObserving {
    bool averaging = false;  ///< the published estimate averages fresh windows (window_average.h)
    int counted = 0;         ///< fresh windows counted
  };
  BeforeObserving beforeObserving() const;  ///< REQUIRES(mutex_)
  /// With averaging: adds the solve's estimate `e` to the average and makes `e` the mean when
  /// its window was counted and agreed; else returns why it is held.
  std::string averageOrHold(const BeforeObserving& before,
                            OnlineEstimate* e);  ///< REQUIRES(mutex_)
  /// Records a solve's result and publishes it when the publish policy lets it.
  bool concludeSolve(const WindowSolveInput& input, uint64_t generation, WindowSolveResult result,
                     std::string* msg, OnlineEstimate* published);

  /// Intrinsics + initial extrinsics. Written (alignRowsOnce) and read on the keyframe thread;
  /// other threads read copies under `mutex_` (startSolve, rig()).
  StereoRig rig_;
  OnlineSettings settings_;
  mutable std::mutex mutex_;
  KeyframeWindow window_;                     ///< GUARDED_BY(mutex_)
  std::optional<OnlineEstimate> estimate_;    ///< GUARDED_BY(mutex_)
  std::optional<OnlineEstimate> last_solve_;  ///< GUARDED_BY(mutex_)
  double last_stamp_ = -1e300;                ///< GUARDED_BY(mutex_)
  double last_keyframe_stamp_ = -1e300;       ///< GUARDED_BY(mutex_)
  int new_keyframes_ = 0;                     ///< GUARDED_BY(mutex_) since the last solve
  /// GUARDED_BY(mutex_): counts window clears (reset, time going backwards, also as soon as
  /// noteStamp sees it); a solve that sees it change between its snapshot and its result
  /// discards the result.
  uint64_t generation_ = 0;
  uint64_t solves_kept_ = 0;  ///< GUARDED_BY(mutex_), OnlineEstimate::solve_id
  std::atomic<bool> cancel_{false};
  /// The last frame's scan, for the next keyframe's de-skewing (OnlineSettings::deskew).
  std::shared_ptr<const LidarScan> previous_scan_;  ///< GUARDED_BY(mutex_)
  double previous_scan_stamp_ = -1e300;             ///< GUARDED_BY(mutex_)
  bool rows_aligned_ = false;  ///< GUARDED_BY(mutex_) OnlineSettings::align_rows done
  bool rows_checked_ = false;  ///< GUARDED_BY(mutex_) OnlineSettings::max_row_offset_px done
  int next_search_start_ = 0;  ///< GUARDED_BY(mutex_) OnlineSettings::spread_search
  /// GUARDED_BY(mutex_): the published full co-calibration's LiDAR sensitivity to the pair, for
  /// the warm updates after it (CoCalibrationSettings::reuse_lidar_sensitivity).
  std::optional<Matrix6d> co_sensitivity_;
  CalibrationMonitor monitor_;  ///< GUARDED_BY(mutex_)
  /// GUARDED_BY(mutex_): the newest keyframes admitted, whether the window keeps them or not
  /// (at most twice MonitorSettings::pair_check_keyframes), for the pair check.
  std::deque<std::shared_ptr<const Keyframe>> recent_;
  WindowAverage average_;  ///< GUARDED_BY(mutex_) the fresh windows the published estimate averages
};

}  // namespace tescalib
