// CalibrationNodelet's health reporting: /diagnostics (what the node is doing, why it is not
// calibrating, its timings) and the watchdog that says which topics stay silent.
#include <cmath>
#include <string>

#include <tescalib/CalibrationStatus.h>

#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/ros/calibration_nodelet.h"

namespace tescalib {

std::string CalibrationNodelet::silentTopics() const {
  const std::string topics[5] = {cloud_sub_.getSubscriber().getTopic(), left_sub_.getTopic(),
                                 left_info_sub_.getSubscriber().getTopic(), right_sub_.getTopic(),
                                 right_info_sub_.getSubscriber().getTopic()};
  std::string silent;
  for (int i = 0; i < 5; ++i)
    if (topic_messages_[i] == 0) silent += (silent.empty() ? "" : ", ") + topics[i];
  return silent;
}

void CalibrationNodelet::startDiagnostics(ros::NodeHandle& nh, ros::NodeHandle& pnh) {
  // Named after the nodelet, not the manager it runs in ("/tescalib: calibration"), so that two
  // calibrations in one manager are told apart.
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID("tescalib");
  diagnostics_->add("calibration", this, &CalibrationNodelet::diagnose);
}

void CalibrationNodelet::watchdog(const ros::WallTimerEvent&) {
  diagnostics_->force_update();
  if (!param_error_.empty()) {
    NODELET_ERROR_THROTTLE(10.0, "tescalib: %s; the node does nothing", param_error_.c_str());
    return;
  }
  if (sync_sets_ > 0) return;
  const std::string silent = silentTopics();
  const std::string check =
      "check the topic names (points:=TOPIC; left:= and right:= are the cameras' namespaces, "
      "image:= the image's name in them, camera_info beside it) and that their sources run";
  std::string what;
  const int left_images = topic_messages_[1];
  const double waited = (ros::WallTime::now() - start_wall_).toSec();
  if (left_images > 20) {
    what = std::to_string(left_images) + " images but no synchronized set: " +
           (silent.empty() ? "check that the cloud, both images and both camera_info topics "
                             "carry matching stamps (sync/approximate, sync/max_skew)"
                           : "nothing on " + silent + "; " + check);
  } else if (!silent.empty() && waited > 5.0) {
    what = "no messages on " + silent + " after " + std::to_string(static_cast<int>(waited)) +
           " s; " + check;
  }
  if (what.empty()) return;
  NODELET_WARN_THROTTLE(10.0, "tescalib: %s", what.c_str());
  noteProblem(what);
}

void CalibrationNodelet::noteProblem(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_problem_ = what;
}

void CalibrationNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const auto e = calibrator() ? calibrator()->estimate() : std::nullopt;
  std::string problem, solve_msg;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    problem = last_problem_;
    solve_msg = last_solve_message_;
  }
  if (!param_error_.empty()) {
    stat.summary(diagnostic_updater::DiagnosticStatusWrapper::ERROR, param_error_);
    return;
  }
  // The last converged solve that was not published: how far from the published estimate.
  double kept_back_chi2 = std::nan("");
  std::string weakest = "none yet";  // the last solve's weakest LiDAR direction
  if (calibrator())
    if (const auto last = calibrator()->lastSolve()) {
      if (!last->message.empty()) kept_back_chi2 = last->chi2_to_published;
      if (last->weakest_lidar.ratio > 0) weakest = describeWeakest(last->weakest_lidar);
    }
  double since_last_set = -1;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (sync_sets_ > 0) since_last_set = (ros::WallTime::now() - last_set_wall_).toSec();
  }
  summarize(stat, e, problem, since_last_set, kept_back_chi2);
  stat.add("last solve chi2 to the published estimate", kept_back_chi2);
  stat.add("last solve weakest LiDAR direction", weakest);
  stat.add("window fill", calibrator() ? calibrator()->windowFill() : 0);
  stat.add("window size", params_.online.window_size);
  stat.add("keyframes", keyframes_.load());
  stat.add("synchronized sets", sync_sets_.load());
  stat.add("seconds since last synchronized set", since_last_set);
  stat.add("dropped keyframe candidates", dropped_.load());
  stat.add("rejected frames", rejected_.load());
  stat.add("last solve seconds", last_solve_seconds_.load());
  stat.add("last solve", solve_msg);
  stat.add("solving", solving_.load());
  addTimings(stat);
  addQuality(stat);
  stat.add("last problem", problem);
  stat.add("unknown parameters", unknown_params_);
  stat.add("converged", e ? e->converged : false);
}

namespace {

/// The monitor's worst state over both extrinsics, as /diagnostics' level and message; OK with
/// an empty message when neither is suspect, changed or recalibrating.
std::pair<unsigned char, std::string> monitorSummary(const MonitorReport& r) {
  using Status = diagnostic_updater::DiagnosticStatusWrapper;
  std::pair<unsigned char, std::string> worst{Status::OK, ""};
  const std::pair<const char*, const MonitorStatus*> both[2] = {
      {"lidar_to_left", &r.lidar_to_left}, {"left_to_right", &r.left_to_right}};
  for (const auto& [name, s] : both) {
    if (s == &r.left_to_right && !r.stereo_monitored) continue;
    const unsigned char level =
        s->state == MonitorState::kChanged ? Status::ERROR
        : s->state == MonitorState::kSuspect || s->state == MonitorState::kRecalibrating
            ? Status::WARN
            : Status::OK;
    if (level <= worst.first) continue;
    char buf[200];
    std::snprintf(buf, sizeof buf, "monitor: %s %s since %.2f s (evidence %.1f chi2)", name,
                  monitorStateName(s->state), s->since, s->evidence);
    worst = {level, buf};
  }
  return worst;
}

}  // namespace

void CalibrationNodelet::publishStatus() {
  if (!calibrator()) return;
  const MonitorReport r = calibrator()->monitorReport();
  CalibrationStatus m;
  const auto last = calibrator()->lastSolve();
  if (last) m.header.stamp = rosStamp(last->stamp);
  m.action = params_.online.monitor.action;
  m.lidar_to_left = monitorStateName(r.lidar_to_left.state);
  m.lidar_to_left_since = r.lidar_to_left.since;
  m.lidar_to_left_evidence = r.lidar_to_left.evidence;
  m.lidar_to_left_last_chi2 = r.lidar_to_left.last_chi2;
  if (r.stereo_monitored) {
    m.left_to_right = monitorStateName(r.left_to_right.state);
    m.left_to_right_since = r.left_to_right.since;
    m.left_to_right_evidence = r.left_to_right.evidence;
    m.left_to_right_last_chi2 = r.left_to_right.last_chi2;
  }
  status_pub_.publish(m);
}

void CalibrationNodelet::summarize(diagnostic_updater::DiagnosticStatusWrapper& stat,
                                   const std::optional<OnlineEstimate>& e,
                                   const std::string& problem, double since_last_set,
                                   double kept_back_chi2) const {
  if (!calibrator() && sync_sets_ > 0 && !problem.empty())
    // Sets come but the node cannot start from them (no initial extrinsic, a frame clash, ...).
    stat.summary(diagnostic_updater::DiagnosticStatusWrapper::WARN, "not started: " + problem);
  else if (!calibrator())  // with what is missing when that is known (the topics silent so far)
    stat.summary(diagnostic_updater::DiagnosticStatusWrapper::WARN,
                 "waiting for synchronized data" + (problem.empty() ? "" : ": " + problem));
  else if (since_last_set > kStaleSeconds)
    // The estimate stays on tf and on the latched topics, but nothing is being calibrated.
    stat.summaryf(diagnostic_updater::DiagnosticStatusWrapper::WARN,
                  "no synchronized set for %.0f s (%s)", since_last_set,
                  e ? "last estimate kept" : "no converged estimate yet");
  else if (!e)
    stat.summary(diagnostic_updater::DiagnosticStatusWrapper::WARN, "no converged estimate yet");
  else if (const auto m = monitorSummary(calibrator()->monitorReport()); !m.second.empty())
    stat.summary(m.first, m.second);
  else if (kept_back_chi2 > params_.online.changed_chi2)
    // A converged solve kept back that the published estimate's covariance cannot explain.
    stat.summaryf(diagnostic_updater::DiagnosticStatusWrapper::WARN,
                  "the last solve is %.1f chi2 (6 DoF) from the published estimate: the extrinsic "
                  "may have changed (the estimate is kept; ~reset recalibrates)",
                  kept_back_chi2);
  else
    stat.summary(diagnostic_updater::DiagnosticStatusWrapper::OK, "calibrated");
}

void CalibrationNodelet::addTimings(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  stat.add("pending sets", queue_.size());
  stat.add("keyframe build mean seconds", build_time_.mean());
  stat.add("keyframe build max seconds", build_time_.max);
  stat.add("keyframe build recent mean seconds", build_time_.recentMean());
  stat.add("solves", solve_time_.count);
  stat.add("solve mean seconds", solve_time_.mean());
  stat.add("solve max seconds", solve_time_.max);
  stat.add("solve recent mean seconds", solve_time_.recentMean());
  stat.add("update latency count", update_latency_.count);
  stat.add("update latency mean seconds", update_latency_.mean());
  stat.add("update latency max seconds", update_latency_.max);
  stat.add("update latency recent mean seconds", update_latency_.recentMean());
  stat.add("update latency recent max seconds", update_latency_.recentMax());
  stat.add("first estimate after keyframes", first_estimate_keyframes_);
  stat.add("first estimate wall seconds", first_estimate_wall_s_);
  stat.add("first estimate sensor seconds", first_estimate_sim_s_);
}

}  // namespace tescalib
