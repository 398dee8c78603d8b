// Scores an online calibration run on a drive whose rig changes (tescalib_simulate
// --extrinsic-step): every estimate the calibrator published or held back, each against the
// truth of its moment. How soon the monitor noticed the change, how soon a published estimate
// was right again, whether anything published in between made tf worse, and false alarms.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/online/calibration_monitor.h"

namespace tescalib {

/// One solve's estimate of one extrinsic, as tescalib_calibrate --json records it.
struct MonitoredEstimate {
  double time = 0;         ///< the recording's time (s), as times.txt
  bool published = false;  ///< it replaced the published estimate
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();
  MonitorState monitor = MonitorState::kCalibrating;
};

/// The truth of one extrinsic: `before` until `step_at` s of the drive, `after` from then on.
struct ExtrinsicTruth {
  Eigen::Isometry3d before = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d after = Eigen::Isometry3d::Identity();
  double step_at = -1;  ///< < 0: the extrinsic does not change
  bool steps() const { return step_at >= 0; }
  const Eigen::Isometry3d& at(double t) const { return steps() && t >= step_at ? after : before; }
};

/// What "right again" means: within both sizes of the truth of the moment. Errors compare in
/// these units; two closer than `tie` of them are equally far (a tenth: 0.005 deg / 1 mm).
struct MonitorTargets {
  double rot_deg = 0.05;
  double trans_m = 0.01;
  double tie = 0.1;
};

struct MonitorScore {
  static constexpr double kNever = std::numeric_limits<double>::quiet_NaN();
  int solves = 0, published = 0;
  double suspect_share = 0;  ///< the share of the solves with the monitor `suspect`
  int changes = 0;           ///< `changed` declared
  int false_changes = 0;     ///< `changed` declared before the step (without one: any)
  /// Seconds of driving from the step to the first solve at or after it with the monitor
  /// `suspect`, `changed`; NaN: never.
  double suspect_delay = kNever, changed_delay = kNever;
  /// The first estimate published at or after the step: its delay and error to the new truth.
  double first_published_delay = kNever, first_published_rot_deg = kNever,
         first_published_trans_m = kNever;
  /// The first estimate published at or after the step within the targets of the new truth.
  double recovered_delay = kNever;
  /// Estimates published from the step until that one (or the end) farther from the truth of
  /// their moment than the estimate they replaced (farther: the larger of rotation / rot_deg and
  /// translation / trans_m is larger by more than MonitorTargets::tie).
  int worse_replacements = 0;
  /// The last published estimate's error to the truth at the end of the run.
  double last_rot_deg = kNever, last_trans_m = kNever;
};

/// Scores `run` (in time order) against `truth`.
MonitorScore scoreMonitorRun(const std::vector<MonitoredEstimate>& run, const ExtrinsicTruth& truth,
                             const MonitorTargets& targets = MonitorTargets());

/// "calibrating" ... "recalibrating" back to the state; false for another name.
bool parseMonitorState(const std::string& name, MonitorState* state);

}  // namespace tescalib
