// The coarse stage of the LiDAR-stereo calibration (paper, "Coarse Calibration"): the
// association of eq. KD6 and the point-to-plane objective with normals of
// eq. point_plane_normal_obj, re-associated within each of a shrinking sequence of gates. It
// brings an estimate from a bad initial guess into the fine stage's basin.
#pragma once

#include <vector>

#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/lidar_stereo_update.h"

namespace tescalib {

/// Runs the coarse stage on `estimate` (per gate of LidarStereoSettings::coarse_gates, up to
/// coarse_reassociations re-associations, until the update is below converge_*). Counts its
/// re-associations in `result->iterations` and its last association set in
/// `result->coarse_inliers`. A Ceres failure sets `estimate->solver_failed` and ends the stage.
/// Returns false when cancelled (then `result->message` says so).
bool runCoarseStage(const std::vector<const Keyframe*>& window, const LidarStereoSettings& settings,
                    LidarStereoEstimate* estimate, LidarStereoResult* result);

}  // namespace tescalib
