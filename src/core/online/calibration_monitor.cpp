#include "tescalib/core/online/calibration_monitor.h"

#include <algorithm>
#include <cmath>

namespace tescalib {

const char* monitorStateName(MonitorState state) {
  switch (state) {
    case MonitorState::kCalibrating:
      return "calibrating";
    case MonitorState::kCalibrated:
      return "calibrated";
    case MonitorState::kSuspect:
      return "suspect";
    case MonitorState::kChanged:
      return "changed";
    case MonitorState::kRecalibrating:
      return "recalibrating";
  }
  return "unknown";
}

bool ExtrinsicMonitor::setState(MonitorState state, double stamp) {
  if (status_.state == state) return false;
  status_.state = state;
  status_.since = stamp;
  return true;
}

bool ExtrinsicMonitor::observe(const std::vector<double>& stamps, double chi2) {
  const MonitorState s = status_.state;
  if (stamps.empty() || !std::isfinite(chi2)) return false;
  // Only a calibrated or suspect extrinsic is checked; `changed` holds until recalibrated or
  // reset, and the other states have no estimate to check against.
  if (s != MonitorState::kCalibrated && s != MonitorState::kSuspect) return false;
  const long fresh =
      std::count_if(stamps.begin(), stamps.end(), [this](double t) { return t > last_newest_; });
  if (fresh < settings_.fresh_fraction * static_cast<double>(stamps.size())) return false;
  const double newest = *std::max_element(stamps.begin(), stamps.end());
  last_newest_ = newest;
  ++status_.fresh_windows;
  status_.last_chi2 = chi2;
  status_.evidence = std::max(0.0, status_.evidence + chi2 - settings_.cusum_k);
  if (status_.evidence <= 0) return setState(MonitorState::kCalibrated, newest);
  if (s == MonitorState::kCalibrated) {
    status_.change_after = newest;
    return setState(MonitorState::kSuspect, newest);
  }
  if (status_.evidence >= settings_.cusum_h &&
      newest - status_.since >= settings_.change_span_s - 1e-9)
    return setState(MonitorState::kChanged, newest);
  return false;
}

void ExtrinsicMonitor::published(double newest) {
  setState(MonitorState::kCalibrated, newest);
  status_.evidence = 0;
  status_.fresh_windows = 0;
  last_newest_ = std::max(last_newest_, newest);
}

void ExtrinsicMonitor::restarted() {
  if (status_.state != MonitorState::kChanged) return;
  status_.state = MonitorState::kRecalibrating;  // since: kept from `changed`
}

}  // namespace tescalib
