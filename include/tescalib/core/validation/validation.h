// A calibration's validation: each criterion's score on a ValidationSet (the mean over its
// frames with the frames' standard error), how much the score changes for a step of 0.1 deg /
// 1 cm along each axis of T_cam_lidar (central finite differences, paired frame by frame), and
// along which axes the score would get better (where that change is larger than the frames'
// scatter can explain). Steps perturb T_cam_lidar as perturb() does: a rotation about and a
// translation along the left camera's axes; T_right_left is held.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/validation/validation_set.h"

namespace tescalib {

/// A mean over frames and its standard error (sample standard deviation / sqrt(frames); 0 for
/// one frame).
struct ScoreSummary {
  double mean = 0;
  double standard_error = 0;
  int frames = 0;
};

ScoreSummary summarize(const std::vector<double>& values);
/// The summary of the frame-by-frame differences a - b (frames of one set, in one order).
ScoreSummary pairedDifference(const std::vector<double>& a, const std::vector<double>& b);
/// The two-sided 95 % quantile of Student's t with frames - 1 degrees of freedom (infinity for
/// fewer than 2 frames): a mean is significantly non-zero when |mean| > this * standard error.
double significanceFactor(int frames);
bool significant(const ScoreSummary& s);

struct CriterionValidation {
  ScoreSummary score;
  /// (score(+step) - score(-step)) / 2 per axis [rx ry rz tx ty tz]: the change per step.
  Vector6d gradient = Vector6d::Zero();
  Vector6d gradient_se = Vector6d::Zero();
  /// (score(+step) + score(-step)) / 2 - score: the change both steps share (negative for a
  /// maximum, positive for a minimum).
  Vector6d curvature = Vector6d::Zero();
  Vector6d curvature_se = Vector6d::Zero();
  /// The score's mean |change| for a step +- along the axis: the criterion's sensitivity.
  Vector6d sensitivity = Vector6d::Zero();
  /// +1 / -1: the score gets significantly better along + / - the axis; 0: not significantly.
  std::array<int, 6> direction{};
  /// Whether a step along the axis changes the score significantly (either way): the axes the
  /// criterion sees on these frames.
  std::array<bool, 6> sees{};
};

struct Validation {
  std::array<CriterionValidation, kCriteria> criteria;
  FrameScores frames;  ///< the per-frame scores at the calibration itself
};

/// The criterion's per-frame scores of a calibration, negated where lower is better: larger is
/// better.
std::vector<double> betterScores(ValidationSet& set, Criterion c, const Eigen::Isometry3d& T,
                                 const Eigen::Isometry3d& T_right_left);

/// The step per axis [rad x3; m x3] of the settings.
Vector6d validationStep(const ValidationSettings& s);

/// Scores the calibration and, when `sensitivities`, its 12 neighbours a step away.
Validation validateCalibration(ValidationSet& set, const Eigen::Isometry3d& T_cam_lidar,
                               const Eigen::Isometry3d& T_right_left, bool sensitivities = true);

/// The criterion's optimum near `T_start`: a direction-set search (Powell): line searches along
/// the six axes (each sampled at -4..4 steps around the current pose, the best sample refined by
/// a parabola) and along each sweep's net move, up to 3 sweeps per round, the step halved after
/// each round; `rounds` rounds from 4 times the settings' step (0.4 deg / 4 cm).
Eigen::Isometry3d criterionOptimum(ValidationSet& set, Criterion c,
                                   const Eigen::Isometry3d& T_start,
                                   const Eigen::Isometry3d& T_right_left, int rounds = 3);

}  // namespace tescalib
