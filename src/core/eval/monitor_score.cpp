#include "tescalib/core/eval/monitor_score.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tescalib/core/common/geometry.h"

namespace tescalib {
namespace {

struct Error {
  double rot_deg, trans_m;
  /// The larger of the two in units of the targets.
  double scaled(const MonitorTargets& t) const {
    return std::max(rot_deg / t.rot_deg, trans_m / t.trans_m);
  }
};

Error errorOf(const Eigen::Isometry3d& T, const Eigen::Isometry3d& truth) {
  const Vector6d e = poseError(T, truth);
  return {e.head<3>().norm() * kDegPerRad, e.tail<3>().norm()};
}

/// The delays after the step: the monitor's first suspect / changed, the first published estimate
/// and the first one within the targets.
void scoreAfterStep(const std::vector<MonitoredEstimate>& run, const ExtrinsicTruth& truth,
                    const MonitorTargets& targets, MonitorScore* s) {
  const Eigen::Isometry3d* replaced = nullptr;  // the estimate on tf
  for (const MonitoredEstimate& e : run) {
    const bool after = e.time >= truth.step_at;
    const double delay = e.time - truth.step_at;
    if (after && std::isnan(s->suspect_delay) && e.monitor == MonitorState::kSuspect)
      s->suspect_delay = delay;
    if (after && std::isnan(s->changed_delay) && e.monitor == MonitorState::kChanged)
      s->changed_delay = delay;
    if (!e.published) continue;
    const Error err = errorOf(e.T, truth.at(e.time));
    if (after && std::isnan(s->recovered_delay)) {
      if (std::isnan(s->first_published_delay)) {
        s->first_published_delay = delay;
        s->first_published_rot_deg = err.rot_deg;
        s->first_published_trans_m = err.trans_m;
      }
      if (replaced &&
          err.scaled(targets) > errorOf(*replaced, truth.at(e.time)).scaled(targets) + targets.tie)
        ++s->worse_replacements;
      if (err.rot_deg <= targets.rot_deg && err.trans_m <= targets.trans_m)
        s->recovered_delay = delay;
    }
    replaced = &e.T;
  }
}

}  // namespace

MonitorScore scoreMonitorRun(const std::vector<MonitoredEstimate>& run, const ExtrinsicTruth& truth,
                             const MonitorTargets& targets) {
  MonitorScore s;
  int suspect = 0;
  const MonitoredEstimate* last = nullptr;
  for (const MonitoredEstimate& e : run) {
    ++s.solves;
    suspect += e.monitor == MonitorState::kSuspect;
    if (e.monitor == MonitorState::kChanged) {
      ++s.changes;
      s.false_changes += !truth.steps() || e.time < truth.step_at;
    }
    if (!e.published) continue;
    ++s.published;
    last = &e;
  }
  if (s.solves > 0) s.suspect_share = static_cast<double>(suspect) / s.solves;
  if (last) {
    const Error err = errorOf(last->T, truth.at(run.back().time));
    s.last_rot_deg = err.rot_deg;
    s.last_trans_m = err.trans_m;
  }
  if (truth.steps()) scoreAfterStep(run, truth, targets, &s);
  return s;
}

bool parseMonitorState(const std::string& name, MonitorState* state) {
  for (MonitorState m :
       {MonitorState::kCalibrating, MonitorState::kCalibrated, MonitorState::kSuspect,
        MonitorState::kChanged, MonitorState::kRecalibrating})
    if (name == monitorStateName(m)) {
      *state = m;
      return true;
    }
  return false;
}

}  // namespace tescalib
