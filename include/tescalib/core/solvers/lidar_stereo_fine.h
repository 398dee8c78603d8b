// The fine stage of the LiDAR-stereo calibration (paper, "Fine Calibration"): projective
// association and the objective of eq. point_point_normal_obj, the LiDAR face's normal setting
// the direction in which its centroid and the stereo point F(d + w) are compared, re-associated
// until the updates settle.
#pragma once

#include <vector>

#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/lidar_stereo_update.h"

namespace tescalib {

/// Runs the fine stage on `estimate` (up to fine_reassociations re-associations). Sets
/// `estimate->settled` when the updates fall below fine_settle_* and keeps the last association
/// set in `estimate->fine_associations`; counts its re-associations in `result->iterations` and
/// the last set in `result->fine_inliers`. A Ceres failure sets `estimate->solver_failed`.
/// Returns false when cancelled (then `result->message` says so).
bool runFineStage(const std::vector<const Keyframe*>& window, const LidarStereoSettings& settings,
                  LidarStereoEstimate* estimate, LidarStereoResult* result);

/// Where an unsettled fine stage was heading ([phi; tau]), from its updates in order: the sum of
/// the last half of them plus what a steady creep would still add (the geometric series of the
/// last update with the ratio rho of successive updates along the drift, in units of the trust
/// limits max_sigma_*; rho clipped to [0, 0.99], so an undamped creep counts 99 more updates).
/// A decaying sequence adds little, an alternating one nothing.
Vector6d unsettledDrift(const std::vector<Vector6d>& updates, const LidarStereoSettings& settings);

/// How far (in units of the trust limits max_sigma_*) the same creep would still carry the
/// estimate from the last update on: the geometric series of unsettledDrift without the updates
/// already made. A fine stage whose last update is small but whose updates keep one direction
/// without shrinking has not reached its fixed point.
double walkAhead(const std::vector<Vector6d>& updates, const LidarStereoSettings& settings);

}  // namespace tescalib
