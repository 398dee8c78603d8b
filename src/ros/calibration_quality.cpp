// CalibrationNodelet's quality scores (quality/enabled): each published estimate and the initial
// guess scored on the estimate's keyframes with the validation criteria (core/validation/
// window_quality.h), for ~lidar_to_left's quality_* fields and /diagnostics.
#include <algorithm>
#include <string>

#include "tescalib/ros/calibration_nodelet.h"

namespace tescalib {

void CalibrationNodelet::startQuality(const StereoRig& rig) {
  if (!params_.quality_enabled) return;
  ValidationSettings settings;
  settings.stereo = keyframeSettings(params_.online).stereo;  // the keyframes' clouds
  quality_ = std::make_unique<WindowQuality>(rig, settings);
  // A keyframe still waiting is still in the window; beyond a window's worth the oldest go (the
  // scoring prepares a keyframe that was not).
  const size_t capacity = static_cast<size_t>(std::max(1, params_.online.window_size));
  quality_prep_ = std::make_unique<BackgroundWorker<std::shared_ptr<const Keyframe>>>(
      [this](std::shared_ptr<const Keyframe>& kf) {
        const ros::WallTime t0 = ros::WallTime::now();
        quality_->prepare(kf);
        std::lock_guard<std::mutex> lock(mutex_);
        quality_prepare_time_.add((ros::WallTime::now() - t0).toSec());
      },
      capacity, kQualityPreparationNice);
}

std::optional<WindowQualityScores> CalibrationNodelet::scoreQuality(const OnlineEstimate& e) {
  if (!quality_) return std::nullopt;  // quality/enabled false
  const auto keyframes = calibrator()->windowKeyframes(e.stamp);
  if (keyframes.empty()) return std::nullopt;  // a reset cleared the window meanwhile
  const WindowQualityScores q = quality_->score(keyframes, e.T_cam_lidar, e.T_right_left);
  std::lock_guard<std::mutex> lock(mutex_);
  quality_time_.add(q.seconds);
  return q;
}

void CalibrationNodelet::addQuality(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  // One row per criterion: "edge_alignment 0.2310 (initial 0.2070: better, significant)".
  for (Criterion c : kAllCriteria)
    stat.add(std::string("quality ") + criterionName(c),
             published_quality_        ? published_quality_->describe(c)
             : params_.quality_enabled ? "no estimate yet"
                                       : "off (quality/enabled)");
  stat.add("quality keyframes", published_quality_ ? published_quality_->keyframes : 0);
  stat.add("quality scoring mean seconds", quality_time_.mean());
  stat.add("quality scoring max seconds", quality_time_.max);
  stat.add("quality keyframe preparation mean seconds", quality_prepare_time_.mean());
  if (quality_prep_) {
    stat.add("quality keyframes prepared ahead", quality_prep_->done());
    stat.add("quality keyframes left to the scoring", quality_prep_->dropped());
    if (quality_prep_->failed() > 0)
      stat.add("quality keyframe preparation error", quality_prep_->lastError());
  }
}

}  // namespace tescalib
