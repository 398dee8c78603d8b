#include "calibrate_monitor.h"

#include <cstdio>
#include <fstream>

namespace tescalib::calibrate {
namespace {

nlohmann::json entry(double time, const char* extrinsic, bool published, const Eigen::Isometry3d& T,
                     const Matrix6d& covariance, MonitorState state) {
  std::vector<double> t, c;
  for (int r = 0; r < 4; ++r)
    for (int k = 0; k < 4; ++k) t.push_back(T.matrix()(r, k));
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) c.push_back(covariance(r, k));
  return {{"time", time}, {"extrinsic", extrinsic}, {"published", published},
          {"T", t},       {"covariance", c},        {"monitor", monitorStateName(state)}};
}

}  // namespace

MonitorState MonitorLog::noteState(const char* name, const MonitorStatus& now, MonitorState* before,
                                   int* changes) {
  char buf[240];
  // With monitor/action recalibrate the solve that declares a change also restarts the window:
  // `changed` and `recalibrating` come together.
  const bool declared = now.changes > *changes;
  *changes = now.changes;
  if (declared) {
    std::snprintf(buf, sizeof buf,
                  "%s changed at %.2f s (evidence %.1f, last chi2 %.1f; keyframes after %.2f s "
                  "are after the change)",
                  name, now.changed_at, now.evidence, now.last_chi2, now.change_after);
    std::printf("  monitor: %s\n", buf);
    changes_.push_back(buf);
  }
  if (now.state != *before && !(declared && now.state == MonitorState::kChanged)) {
    std::snprintf(buf, sizeof buf, "%s %s at %.2f s (evidence %.1f, last chi2 %.1f)", name,
                  monitorStateName(now.state), now.since, now.evidence, now.last_chi2);
    std::printf("  monitor: %s\n", buf);
    if (*before == MonitorState::kRecalibrating && now.state == MonitorState::kCalibrated)
      changes_.push_back(buf);
  }
  *before = now.state;
  return declared ? MonitorState::kChanged : now.state;
}

void MonitorLog::afterSolve(const OnlineCalibrator& calibrator, bool published) {
  const MonitorReport report = calibrator.monitorReport();
  const MonitorState lidar =
      noteState("lidar_to_left", report.lidar_to_left, &lidar_, &lidar_changes_);
  const MonitorState stereo =
      report.stereo_monitored
          ? noteState("left_to_right", report.left_to_right, &stereo_, &stereo_changes_)
          : report.left_to_right.state;
  const auto solve = calibrator.lastSolve();
  if (!solve || solve->solve_id == last_solve_id_) return;  // the solve failed or was discarded
  last_solve_id_ = solve->solve_id;
  estimates_.push_back(
      entry(solve->stamp, "lidar_to_left", published, solve->T_cam_lidar, solve->cov_lidar, lidar));
  if (solve->stereo_estimated)
    estimates_.push_back(entry(solve->stamp, "left_to_right", published, solve->T_right_left,
                               solve->cov_stereo, stereo));
}

void MonitorLog::printSummary() const {
  if (changes_.empty()) {
    std::printf("monitor: no change of an extrinsic found\n");
    return;
  }
  // The lines hold the changes and the recalibrations after them.
  std::printf("monitor: %d change(s) found:\n", lidar_changes_ + stereo_changes_);
  for (const std::string& c : changes_) std::printf("  %s\n", c.c_str());
}

bool MonitorLog::writeJson(const std::string& path, std::string* error) const {
  std::ofstream out(path);
  if (out) out << nlohmann::json{{"estimates", estimates_}}.dump(1) << "\n";
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  return true;
}

}  // namespace tescalib::calibrate
