#include "tescalib/core/online/online_calibrator.h"

#include <chrono>
#include <cstdio>

#include "tescalib/core/online/publish_policy.h"

namespace tescalib {

OnlineCalibrator::OnlineCalibrator(const StereoRig& rig, const OnlineSettings& settings)
    : rig_(rig),
      settings_(settings),
      window_(settings.window_size, settings.keyframe_selection),
      monitor_(settings.monitor),
      average_(settings.monitor.average_windows) {}

FrameResult OnlineCalibrator::addFrame(const Frame& frame, double lidar_stamp, std::string* msg,
                                       std::shared_ptr<const Keyframe>* built) {
  *msg = frameProblem(frame, lidar_stamp, rig_, settings_);
  if (!msg->empty()) return FrameResult::kRejected;
  Selection selection;
  if (const std::optional<FrameResult> result = selectFrame(frame, msg, &selection)) return *result;
  std::shared_ptr<Keyframe> kf =
      buildTakenKeyframe(frame, lidar_stamp, rig_, selection.inputs, settings_, msg);
  if (!kf) return rejectAfterSelection(frame.stamp, selection.previous_keyframe_stamp);
  bool realigned = false;
  const bool took_row_check = checkRowsOnce(*kf, msg, &realigned);
  if (realigned) kf = rebuildRealigned(frame, lidar_stamp, &selection, msg);
  if (!kf) return rejectAfterSelection(frame.stamp, selection.previous_keyframe_stamp);
  return admitKeyframe(std::move(kf), selection.generation, took_row_check, built, msg);
}

std::optional<FrameResult> OnlineCalibrator::selectFrame(const Frame& frame, std::string* msg,
                                                         Selection* selection) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (frame.stamp < last_stamp_ - settings_.max_time_jump_back) {
    char back[32];
    std::snprintf(back, sizeof back, "%.2f", last_stamp_ - frame.stamp);
    *msg = std::string("time went backwards by ") + back + " s (looping bag?): window cleared";
    if (estimate_)
      *msg += "; the published estimate is kept until a solve from " +
              std::to_string(std::min(estimate_->keyframes_used, settings_.window_size)) +
              " keyframes replaces it";
    clearWindow();
    last_stamp_ = frame.stamp;
    return FrameResult::kReset;
  }
  last_stamp_ = frame.stamp;
  KeyframeInputs& in = selection->inputs;
  if (settings_.deskew) {
    in.previous_scan = previous_scan_;
    in.previous_scan_stamp = previous_scan_stamp_;
    previous_scan_ = std::make_shared<const LidarScan>(frame.scan);
    previous_scan_stamp_ = frame.stamp;
  }
  if (settings_.tooClose(frame.stamp, last_keyframe_stamp_)) return FrameResult::kTooClose;
  selection->previous_keyframe_stamp = last_keyframe_stamp_;
  last_keyframe_stamp_ = frame.stamp;
  in.T_cam_lidar = estimate_ ? estimate_->T_cam_lidar : rig_.T_cam_lidar;
  in.T_right_left = estimate_ ? estimate_->T_right_left : rig_.T_right_left;
  selection->generation = generation_;
  return std::nullopt;
}

FrameResult OnlineCalibrator::rejectAfterSelection(double stamp, double previous_keyframe_stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (last_keyframe_stamp_ == stamp) last_keyframe_stamp_ = previous_keyframe_stamp;
  return FrameResult::kRejected;
}

std::shared_ptr<Keyframe> OnlineCalibrator::rebuildRealigned(const Frame& frame, double lidar_stamp,
                                                             Selection* selection,
                                                             std::string* msg) {
  StereoRig rig;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rig = rig_;
    selection->inputs.T_right_left = rig_.T_right_left;
    selection->generation = generation_;
  }
  std::string problem;
  std::shared_ptr<Keyframe> kf =
      buildTakenKeyframe(frame, lidar_stamp, rig, selection->inputs, settings_, &problem);
  if (!kf) *msg += "; matched again: " + problem;
  return kf;
}

bool OnlineCalibrator::checkRowsOnce(const Keyframe& keyframe, std::string* msg, bool* realigned) {
  bool check_rows = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    check_rows = settings_.max_row_offset_px > 0 && !rows_checked_;
    rows_checked_ = true;
  }
  if (!check_rows) return false;
  const RowCheck rows = checkRowAlignment(keyframe, rig_, settings_);
  if (!rows.decided) {  // too little texture to tell: the next keyframe is checked
    std::lock_guard<std::mutex> lock(mutex_);
    rows_checked_ = false;
  } else {
    *msg = rows.warning;
    if (settings_.align_rows) *realigned = alignRowsOnce(keyframe, rows.rows, msg);
  }
  return true;
}

bool OnlineCalibrator::alignRowsOnce(const Keyframe& keyframe, const VerticalAlignment& rows,
                                     std::string* msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (rows_aligned_ || estimate_) return false;
  rows_aligned_ = true;
  // NaN (not fitted) fails the comparison too.
  if (!(largestRowCorrectionPx(rows, rig_.left) > settings_.align_rows_min_px)) return false;
  const Eigen::Isometry3d aligned =
      rowAlignedExtrinsic(keyframe.T_right_left_used, rows, rig_.right.fy);
  if (aligned.isApprox(keyframe.T_right_left_used)) return false;
  rig_.T_right_left = aligned;
  clearWindow();  // this keyframe and those built alongside it matched the old rows
  char buf[300];
  std::snprintf(buf, sizeof buf,
                "%sthe right image's rows lie %+.3f px (%+.3f px per unit of x) from the stereo "
                "calibration: the pair is re-rectified for the right camera's pitch %+.4f deg and "
                "roll %+.4f deg that explain them; the window restarts with this keyframe matched "
                "again",
                msg->empty() ? "" : "; ", rows.offset_px, rows.slope_x_px,
                -rows.offset_px / rig_.right.fy * kDegPerRad,
                rows.slope_x_px / rig_.right.fy * kDegPerRad);
  *msg += buf;
  return true;
}

FrameResult OnlineCalibrator::admitKeyframe(std::shared_ptr<Keyframe> keyframe, uint64_t generation,
                                            bool took_row_check,
                                            std::shared_ptr<const Keyframe>* built,
                                            std::string* msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (generation_ != generation) {
    // Built from the extrinsics (and, de-skewed, the scans) of a window that is gone: a reset
    // would otherwise find a keyframe of the estimate it cleared in its fresh window. Its row
    // check, if it had the one, is another keyframe's to do.
    if (took_row_check) rows_checked_ = false;
    *msg = (msg->empty() ? "" : *msg + "; ") +
           "the window was cleared while this keyframe was built (reset, or time went backwards, "
           "or the pair re-rectified): dropped";
    return FrameResult::kRejected;
  }
  if (built) *built = keyframe;
  recent_.push_back(keyframe);
  while (static_cast<int>(recent_.size()) > 2 * settings_.monitor.pair_check_keyframes)
    recent_.pop_front();
  window_.add(std::move(keyframe));
  ++new_keyframes_;
  return FrameResult::kKeyframe;
}

void OnlineCalibrator::clearWindow() {
  window_.clear();
  recent_.clear();
  previous_scan_.reset();
  last_solve_.reset();  // it described the window just cleared
  last_keyframe_stamp_ = -1e300;
  new_keyframes_ = 0;
  ++generation_;
  monitor_.lidar_to_left.forgetStamps();
  monitor_.left_to_right.forgetStamps();
}

std::vector<double> OnlineCalibrator::windowStamps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return window_.stamps();
}

std::vector<std::shared_ptr<const Keyframe>> OnlineCalibrator::windowKeyframes(double up_to) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::shared_ptr<const Keyframe>> out;
  for (const auto& k : window_.snapshot(false))
    if (k->stamp <= up_to) out.push_back(k);
  return out;
}

bool OnlineCalibrator::readyToSolve() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(window_.size()) >= settings_.minKeyframes() && new_keyframes_ > 0;
}

size_t OnlineCalibrator::windowFill() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return window_.size();
}

bool OnlineCalibrator::coCalibrationPending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_.estimate_stereo &&
         static_cast<int>(window_.size()) >= settings_.min_keyframes_co &&
         !(last_solve_ && last_solve_->stereo_estimated);
}

bool OnlineCalibrator::solve(std::string* msg, OnlineEstimate* published, bool recording_ended) {
  if (cancel_) {
    *msg = "cancelled";
    return false;
  }
  WindowSolveInput input;
  StereoRig rig;
  uint64_t generation = 0;
  if (!startSolve(recording_ended, &input, &rig, &generation, msg)) return false;
  const auto t0 = std::chrono::steady_clock::now();
  WindowSolveResult result;
  // A solver that throws (a DataError on an estimate gone far off, OpenCV on data it cannot use)
  // fails this solve, not the node: the published estimate stays.
  try {
    result = solveWindow(input, rig, settings_, &cancel_);
    if (!input.pair_check.empty() && !cancel_)
      result.pair_check = checkStereoPair(input.pair_check, rig, *input.published, settings_);
  } catch (const std::exception& ex) {
    *msg = std::string("the solve failed: ") + ex.what() +
           (input.published ? " (keeping the previous estimate)" : " (nothing published yet)");
    return false;
  }
  *msg = result.message;
  OnlineEstimate& e = result.estimate;
  e.keyframes_used = static_cast<int>(input.keyframes.size());
  e.stamp = input.keyframes.back()->stamp;
  e.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return concludeSolve(input, generation, std::move(result), msg, published);
}

bool OnlineCalibrator::startSolve(bool recording_ended, WindowSolveInput* input, StereoRig* rig,
                                  uint64_t* generation, std::string* msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  *generation = generation_;
  *rig = rig_;
  if (window_.empty() || static_cast<int>(window_.size()) < settings_.minKeyframes()) {
    *msg = "window has " + std::to_string(window_.size()) + " keyframes, needs " +
           std::to_string(settings_.minKeyframes());
    return false;
  }
  input->co = coCalibrationDue(settings_, static_cast<int>(window_.size()), estimate_.has_value(),
                               recording_ended);
  // Co-calibration recomputes the stereo clouds in place: it gets deep copies. The LiDAR-stereo
  // solve only reads, and the shared keyframes are never modified after insertion.
  input->keyframes = window_.snapshot(input->co);
  new_keyframes_ = 0;
  input->published = estimate_;
  input->lidar_sensitivity = co_sensitivity_;
  input->T_cam_lidar = estimate_ ? estimate_->T_cam_lidar : rig_.T_cam_lidar;
  input->T_right_left = estimate_ ? estimate_->T_right_left : rig_.T_right_left;
  input->search_start = next_search_start_;
  input->last_converged = !last_solve_ || last_solve_->converged;
  input->recalibrating = recalibrating();
  input->pair_check = pairCheckKeyframes();
  return true;
}

std::vector<std::shared_ptr<const Keyframe>> OnlineCalibrator::pairCheckKeyframes() const {
  const MonitorSettings& m = settings_.monitor;
  if (m.pair_check_keyframes <= 0 || m.action == "off" || !estimate_ ||
      !estimate_->stereo_estimated || holdsChange(monitor_.lidar_to_left.status()))
    return {};
  std::vector<std::shared_ptr<const Keyframe>> fresh;
  for (const auto& k : recent_)
    if (monitor_.left_to_right.isNew(k->stamp)) fresh.push_back(k);
  if (static_cast<int>(fresh.size()) < m.pair_check_keyframes) return {};
  return fresh;
}

bool OnlineCalibrator::concludeSolve(const WindowSolveInput& input, uint64_t generation,
                                     WindowSolveResult result, std::string* msg,
                                     OnlineEstimate* published) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (cancel_) {
    // The solvers poll the flag; a cancel that came after their last poll lets the solve end.
    *msg = result.solver_cancelled ? "cancelled" : "cancelled after the solve had ended";
    return false;
  }
  if (generation_ != generation) {
    *msg =
        "the window was cleared during the solve (reset, or time went backwards): its result "
        "was discarded";
    return false;
  }
  window_.storeInformation(input.keyframes, result.keyframe_information);
  if (result.searched) next_search_start_ = (input.search_start + 1) % 8;
  OnlineEstimate& e = result.estimate;
  e.solve_id = ++solves_kept_;
  e.chi2_to_published = chi2ToPublished(e, estimate_);
  std::string refusal = publicationRefusal(e, estimate_, settings_, *msg, recalibrating());
  const BeforeObserving before = beforeObserving();
  const std::string monitor_note = monitorSolve(input, result);
  if (!monitor_note.empty())
    refusal = refusal.empty() ? monitor_note : refusal + "; " + monitor_note;
  if (refusal.empty() && before.averaging) {
    refusal = averageOrHold(before, &e);
    e.held_between_windows = !refusal.empty();
  }
  if (!refusal.empty()) {
    *msg = refusal;
    last_solve_ = e;
    last_solve_->message = refusal;
    return false;
  }
  if (!before.averaging) average_.restart(e);
  estimate_ = last_solve_ = e;
  const bool full = e.keyframes_used >= settings_.window_size;
  monitor_.lidar_to_left.published(e.stamp, e.T_cam_lidar, e.cov_lidar, full);
  if (e.stereo_estimated)
    monitor_.left_to_right.published(e.stamp, e.T_right_left, e.cov_stereo, full);
  if (result.lidar_sensitivity) co_sensitivity_ = result.lidar_sensitivity;
  // Keep the co-calibration's re-rectified or rescaled clouds. Only with the estimate they were
  // rectified for: an unpublished one's would leave the window on a stereo extrinsic nothing else
  // uses, to be re-rectified back by the next solve.
  if (result.clouds_recomputed) window_.adoptRecomputedClouds(input.keyframes);
  if (published) *published = e;
  return true;
}

namespace {

std::vector<double> stampsOf(const std::vector<std::shared_ptr<Keyframe>>& keyframes) {
  std::vector<double> stamps;
  for (const auto& k : keyframes) stamps.push_back(k->stamp);
  return stamps;
}

}  // namespace

OnlineCalibrator::BeforeObserving OnlineCalibrator::beforeObserving() const {
  const ExtrinsicMonitor& lidar = monitor_.lidar_to_left;
  BeforeObserving b;
  b.averaging = settings_.monitor.action == "recalibrate" &&
                settings_.monitor.average_windows > 1 && estimate_ && lidar.checked() &&
                average_.size() > 0 && !recalibrating();
  b.counted = lidar.status().fresh_windows;
  return b;
}

std::string OnlineCalibrator::averageOrHold(const BeforeObserving& before, OnlineEstimate* e) {
  const ExtrinsicMonitor& lidar = monitor_.lidar_to_left;
  const bool counted = lidar.status().fresh_windows > before.counted &&
                       lidar.lastCountedNewest() == e->stamp &&
                       lidar.status().state == MonitorState::kCalibrated;
  if (!counted) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "held: the published estimate is the mean of %zu fresh window%s, and this "
                  "window overlaps the last one (%.1f chi2 from it)",
                  average_.size(), average_.size() == 1 ? "" : "s", e->chi2_to_published);
    return buf;
  }
  *e = average_.add(*e, lidar.lastFreshShare());
  return "";
}

bool OnlineCalibrator::recalibrating() const {
  return monitor_.lidar_to_left.status().state == MonitorState::kRecalibrating ||
         monitor_.left_to_right.status().state == MonitorState::kRecalibrating;
}

void OnlineCalibrator::observeLidar(const WindowSolveInput& input,
                                    const WindowSolveResult& result) {
  const OnlineEstimate& e = result.estimate;
  const std::vector<double> stamps = stampsOf(input.keyframes);
  if (e.converged && e.cov_lidar_known)
    monitor_.lidar_to_left.observe(stamps, e.T_cam_lidar, e.cov_lidar);
  else if (const auto& half = result.newer_half)
    monitor_.lidar_to_left.observe(half->stamps, half->T_cam_lidar, half->covariance, true,
                                   half->unconstrained);
  else if (result.settled_unconstrained)
    monitor_.lidar_to_left.observe(stamps, e.T_cam_lidar, e.cov_lidar, false,
                                   result.unconstrained_lidar);
}

void OnlineCalibrator::observePair(const WindowSolveInput& input, const WindowSolveResult& result) {
  const OnlineEstimate& e = result.estimate;
  // The pair check first: the window's own left-right estimate then counts only when it is
  // fresh beside it.
  if (const auto& check = result.pair_check)
    monitor_.left_to_right.observe(check->stamps, check->T_right_left, check->covariance);
  if ((e.converged || result.stereo_settled) && e.stereo_estimated && e.cov_stereo_known &&
      estimate_->stereo_estimated)
    monitor_.left_to_right.observe(stampsOf(input.keyframes), e.T_right_left, e.cov_stereo);
}

std::string OnlineCalibrator::monitorSolve(const WindowSolveInput& input,
                                           const WindowSolveResult& result) {
  const MonitorSettings& m = settings_.monitor;
  if (m.action == "off" || !estimate_) return "";
  ExtrinsicMonitor &lidar = monitor_.lidar_to_left, &pair = monitor_.left_to_right;
  // Each extrinsic's evidence is measured through the other (the stereo clouds are rectified for
  // the published pair, the pair check's depths come from the published LiDAR extrinsic): while
  // one holds a change, the other is not checked, and a change declared drops the other's
  // suspicion.
  const bool lidar_held = holdsChange(lidar.status()), pair_held = holdsChange(pair.status());
  if (!pair_held) observeLidar(input, result);
  if (!lidar_held) observePair(input, result);
  if (lidar.status().state == MonitorState::kChanged) pair.dropSuspicion();
  if (pair.status().state == MonitorState::kChanged) lidar.dropSuspicion();
  const MonitorStatus* changed = nullptr;
  std::string note;
  for (const auto* s : {&monitor_.lidar_to_left.status(), &monitor_.left_to_right.status()}) {
    const char* name = s == &monitor_.lidar_to_left.status() ? "lidar_to_left" : "left_to_right";
    if (s->state == MonitorState::kChanged && !changed) changed = s;
    if (s->state != MonitorState::kSuspect && s->state != MonitorState::kChanged) continue;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%smonitor: %s %s since %.2f s (evidence %.1f, chi2 %.1f)",
                  note.empty() ? "" : "; ", name, monitorStateName(s->state), s->since, s->evidence,
                  s->last_chi2);
    note += buf;
  }
  const bool recalibrate = m.action == "recalibrate";
  if (recalibrate && changed) {
    const size_t left = window_.dropUpTo(changed->change_after);
    monitor_.lidar_to_left.restarted();
    monitor_.left_to_right.restarted();
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  ": window restarted from the %zu keyframes after %.2f s, recalibrating", left,
                  changed->change_after);
    note += buf;
  }
  // While suspect, new keyframes push out the oldest, so that fresh windows come to confirm or
  // clear the suspicion (by information, a town's keyframes can stay for minutes on a highway);
  // those pushed out come back when it clears, or, after a change, the ones after it. The same
  // while a co-calibration's halves disagree: the left-right estimate has no halves of its own.
  window_.setOldestFirst(monitor_.lidar_to_left.status().state == MonitorState::kSuspect ||
                         monitor_.left_to_right.status().state == MonitorState::kSuspect ||
                         (result.co_halves_disagree && estimate_->stereo_estimated));
  // With "flag" the monitor only reports: publication goes on as without it.
  return recalibrate ? note : "";
}

MonitorReport OnlineCalibrator::monitorReport() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MonitorReport r;
  r.lidar_to_left = monitor_.lidar_to_left.status();
  r.left_to_right = monitor_.left_to_right.status();
  r.stereo_monitored = settings_.estimate_stereo;
  return r;
}

void OnlineCalibrator::setPreviousScan(std::shared_ptr<const LidarScan> scan, double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  previous_scan_ = std::move(scan);
  previous_scan_stamp_ = stamp;
}

void OnlineCalibrator::noteStamp(double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stamp < last_stamp_ - settings_.max_time_jump_back) ++generation_;
}

void OnlineCalibrator::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  clearWindow();
  estimate_.reset();
  average_.clear();
  co_sensitivity_.reset();
  monitor_.lidar_to_left.reset();
  monitor_.left_to_right.reset();
  rows_checked_ = false;  // a recalibration checks the rows again
  last_stamp_ = -1e300;
}

std::optional<OnlineEstimate> OnlineCalibrator::estimate() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_;
}

std::optional<OnlineEstimate> OnlineCalibrator::lastSolve() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_solve_;
}

StereoRig OnlineCalibrator::rig() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return rig_;
}

Eigen::Isometry3d OnlineCalibrator::currentTcamLidar() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_ ? estimate_->T_cam_lidar : rig_.T_cam_lidar;
}

Eigen::Isometry3d OnlineCalibrator::currentTrightLeft() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_ ? estimate_->T_right_left : rig_.T_right_left;
}

}  // namespace tescalib
