// tescalib_calibrate --holdout N: every Nth keyframe is kept out of the calibration, and the
// estimate, the initial guess and the recording's own calibration are scored on those held-out
// keyframes with the validation criteria (core/validation/): frames the estimate was not fitted
// on, so its advantage there is not biased by the fit.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"

namespace tescalib::calibrate {

/// One calibration scored on the held-out keyframes.
struct HeldOutCalibration {
  std::string name;  ///< "estimate", "initial_guess", "recording"
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
};

/// Whether keyframe `number` (from 0, in the order the recording gives them) is held out with
/// --holdout `every` (every Nth: numbers every-1, 2*every-1, ...; none for every < 2).
inline bool heldOut(int number, int every) { return every >= 2 && number % every == every - 1; }

/// Prints each criterion's mean score of every calibration on `frames` (the first of
/// `calibrations` is compared with each other one, paired frame by frame) and returns the block
/// `held_out:` of BASE.yaml's `quality:` (indented under it). Nothing ("" returned) without frames;
/// when the scores cannot be computed (a pair that cannot be rectified) it says why.
std::string printHeldOut(const std::vector<Frame>& frames, int every, const StereoRig& rig,
                         const std::vector<HeldOutCalibration>& calibrations);

}  // namespace tescalib::calibrate
