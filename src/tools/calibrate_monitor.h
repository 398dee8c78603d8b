// tescalib_calibrate's view of the calibration monitor (calibration_monitor.h): the state changes
// it finds, printed as they happen and summed up at the end, and --json's record of every
// estimate the node would publish or hold back, each with the monitor's state.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tescalib/core/online/online_calibrator.h"

namespace tescalib::calibrate {

class MonitorLog {
 public:
  /// After a solve of `calibrator`; `published`: its estimate replaced the published one.
  void afterSolve(const OnlineCalibrator& calibrator, bool published);
  /// How many changes were found, then each change and each recalibration after one (a line
  /// each), or that none was.
  void printSummary() const;
  /// {"estimates": [{"time", "extrinsic", "published", "T" [16], "covariance" [36],
  /// "monitor"}, ...]}; false with `error` when the file cannot be written.
  bool writeJson(const std::string& path, std::string* error) const;

 private:
  /// Prints a state change of `name`'s monitor (a change declared and the window restarted in
  /// one solve included); returns the state to record for this solve.
  MonitorState noteState(const char* name, const MonitorStatus& now, MonitorState* before,
                         int* changes);

  uint64_t last_solve_id_ = 0;
  MonitorState lidar_ = MonitorState::kCalibrating, stereo_ = MonitorState::kCalibrating;
  int lidar_changes_ = 0, stereo_changes_ = 0;
  std::vector<std::string> changes_;  ///< the lines: changes and recalibrations
  nlohmann::json estimates_ = nlohmann::json::array();
};

}  // namespace tescalib::calibrate
