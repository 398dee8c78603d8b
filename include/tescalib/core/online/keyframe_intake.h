// Keyframe intake of the online calibrator: the checks of a frame before it can be a keyframe,
// its preprocessing (de-skewed scan, mesh, stereo cloud) and the checks of the keyframe built.
// Stateless: the calibrator selects the frames (keyframes at least keyframe_min_dt apart) and
// holds the window.
#pragma once

#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/stereo/row_alignment.h"

namespace tescalib {

/// Why `frame` (its scan stamped `lidar_stamp`) cannot be a keyframe whatever the window holds:
/// an empty scan, a missing image, images not of camera_info's size, stamps not finite or further
/// apart than max_sync_skew. Empty when it can be one.
std::string frameProblem(const Frame& frame, double lidar_stamp, const StereoRig& rig,
                         const OnlineSettings& settings);

/// The keyframes' preprocessing: with co-calibration the stereo clouds take its refinement (every
/// cloud of a co-calibration window is of one kind), with the joint solve the mesh fits every
/// face's normal.
KeyframeSettings keyframeSettings(const OnlineSettings& settings);

/// What a selected frame's keyframe is built with, read when it is selected.
struct KeyframeInputs {
  /// The published estimate, or the initial one.
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  /// The scan before the frame's, for its motion (OnlineSettings::deskew).
  std::shared_ptr<const LidarScan> previous_scan;
  double previous_scan_stamp = -1e300;
};

/// The keyframe of `frame`: the pair's quality checked (pairQualityProblem), the images matched
/// while the scan is de-skewed (OnlineSettings::deskew), then the scan's mesh. Null, with
/// `message` saying why, when the pair fails the checks, the scan cannot be de-skewed or the
/// preprocessing throws.
std::shared_ptr<Keyframe> buildKeyframe(const Frame& frame, double lidar_stamp,
                                        const StereoRig& rig, const KeyframeInputs& inputs,
                                        const OnlineSettings& settings, std::string* message);

/// Why a built keyframe is not taken: too few mesh faces in the cameras' view (and whether the
/// scan lacks rings or T_cam_lidar puts it out of view), or too few stereo points. Empty when it
/// is taken.
std::string keyframeProblem(const Keyframe& keyframe, const LidarScan& scan,
                            const Eigen::Isometry3d& T_cam_lidar, const StereoRig& rig,
                            const OnlineSettings& settings);

/// buildKeyframe, then keyframeProblem: the keyframe when it is taken, else null with `message`
/// saying why.
std::shared_ptr<Keyframe> buildTakenKeyframe(const Frame& frame, double lidar_stamp,
                                             const StereoRig& rig, const KeyframeInputs& inputs,
                                             const OnlineSettings& settings, std::string* message);

/// The stereo calibration checked on a keyframe's pair (OnlineSettings::max_row_offset_px).
struct RowCheck {
  /// The pair has enough texture (100 corners followed) to tell; otherwise the next keyframe is
  /// checked.
  bool decided = false;
  std::string warning;     ///< the right image's rows lie too far off: what that means
  VerticalAlignment rows;  ///< what was measured
};
RowCheck checkRowAlignment(const Keyframe& keyframe, const StereoRig& rig,
                           const OnlineSettings& settings);

}  // namespace tescalib
