// tescalib_calibrate's quality scores: the estimate and the initial guess scored on the window's
// keyframes with the validation criteria (core/validation/), printed and written into BASE.yaml.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"

namespace tescalib::calibrate {

/// Prints, per criterion, "edge_alignment 0.2310 vs 0.2070 for the initial guess (+0.0240 +-
/// 0.0050, better, significant)" for the estimate (T_cam_lidar, T_right_left) against the initial
/// guess (`initial`'s extrinsics) on `keyframes`, and returns the same as BASE.yaml's block
/// `quality:`. Nothing ("" returned) without keyframes; a criterion that cannot be computed
/// (a pair that cannot be rectified) is named instead.
std::string printQuality(const std::vector<Frame>& keyframes, const StereoRig& initial,
                         const Eigen::Isometry3d& T_cam_lidar,
                         const Eigen::Isometry3d& T_right_left);

/// Appends `block` to the result file of `base` (BASE.yaml; a trailing ".yaml" of `base` is
/// dropped as writeCalibrationFiles does). False when the file cannot be written.
bool appendToResultYaml(const std::string& base, const std::string& block);

}  // namespace tescalib::calibrate
