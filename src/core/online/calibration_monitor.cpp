#include "tescalib/core/online/calibration_monitor.h"

#include <algorithm>
#include <cmath>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/uncertainty/trust.h"

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

bool ExtrinsicMonitor::observe(const std::vector<double>& stamps, const Eigen::Isometry3d& T,
                               const Matrix6d& cov, bool newer_half,
                               const std::vector<Vector6d>& unconstrained) {
  const MonitorState s = status_.state;
  if (stamps.empty() || !cov.allFinite()) return false;
  if (!checked()) return false;
  const long fresh =
      std::count_if(stamps.begin(), stamps.end(), [this](double t) { return t > last_newest_; });
  if (fresh < settings_.fresh_fraction * static_cast<double>(stamps.size())) return false;
  const double chi2 = neesIgnoring(poseError(T, reference_), cov + reference_cov_, unconstrained);
  if (!std::isfinite(chi2)) return false;  // the summed covariance is not positive definite
  const auto [oldest_it, newest_it] = std::minmax_element(stamps.begin(), stamps.end());
  const double newest = *newest_it;
  last_newest_ = newest;
  last_fresh_share_ = static_cast<double>(fresh) / static_cast<double>(stamps.size());
  ++status_.fresh_windows;
  status_.last_chi2 = chi2;
  // A window adds at most two thirds of cusum_h: however far off, one alone declares nothing,
  // and its weight drains with the next agreeing windows.
  const double excess = std::min(chi2 - settings_.cusum_k, 2.0 / 3.0 * settings_.cusum_h);
  status_.evidence = std::max(0.0, status_.evidence + excess);
  if (status_.evidence <= 0) {
    run_.clear();
    return setState(MonitorState::kCalibrated, newest);
  }
  run_.push_back({*oldest_it, newest, newer_half, T, cov});  // empty while calibrated
  if (s == MonitorState::kCalibrated) {
    status_.change_after = newest;
    return setState(MonitorState::kSuspect, newest);
  }
  if (status_.evidence >= settings_.cusum_h &&
      newest - status_.since >= settings_.change_span_s - 1e-9) {
    ++status_.changes;
    status_.changed_at = newest;
    status_.change_after = changeAfter();
    return setState(MonitorState::kChanged, newest);
  }
  return false;
}

double ExtrinsicMonitor::changeAfter() const {
  // A window of the run is "before or straddling" when its estimate is farther than cusum_k
  // (chi2, both covariances) from the declaring window's: keyframes up to its newest go.
  const Counted& last = run_.back();
  double after = run_.front().newest;
  for (size_t i = 0; i + 1 < run_.size(); ++i) {
    const double chi2 = nees(poseError(run_[i].T, last.T), run_[i].cov + last.cov);
    if (!(chi2 <= settings_.cusum_k)) after = std::max(after, run_[i].newest);
  }
  return last.newer_half ? std::max(after, std::nextafter(last.oldest, -HUGE_VAL)) : after;
}

void ExtrinsicMonitor::published(double newest, const Eigen::Isometry3d& T, const Matrix6d& cov,
                                 bool full) {
  const MonitorState s = status_.state;
  const bool first = s == MonitorState::kCalibrating || s == MonitorState::kRecalibrating;
  // Otherwise only the estimate of the fresh window just counted, which agreed with the
  // reference: one from a window overlapping the next fresh one would hide a change from it.
  if (!first && !provisional_ && !(s == MonitorState::kCalibrated && newest == last_newest_))
    return;
  if (first) {
    setState(MonitorState::kCalibrated, newest);
    status_.evidence = 0;
    run_.clear();  // the windows before a recalibration
  }
  if (first || provisional_) last_newest_ = std::max(last_newest_, newest);
  provisional_ = !full;
  reference_ = T;
  reference_cov_ = cov;
}

void ExtrinsicMonitor::restarted() {
  if (status_.state != MonitorState::kChanged) return;
  status_.state = MonitorState::kRecalibrating;  // since: kept from `changed`
}

void ExtrinsicMonitor::dropSuspicion() {
  if (status_.state != MonitorState::kSuspect) return;
  status_.evidence = 0;
  run_.clear();
  setState(MonitorState::kCalibrated, status_.since);
}

}  // namespace tescalib
