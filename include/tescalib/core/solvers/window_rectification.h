// A window's stereo clouds following the left-right estimate: when a cloud rectified with one
// estimate must be triangulated again (or matched again) for another, and bringing a window's
// clouds to an estimate (co-calibration's re-rectification, paper "Co-calibration").
#pragma once

#include <vector>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/keyframe.h"

namespace tescalib {

/// How the left-right extrinsic `now` differs from the one stereo clouds were rectified with.
struct RectificationChange {
  Eigen::Vector3d phi;        ///< rotation between the right cameras (right frame; y: the yaw)
  Eigen::Vector3d direction;  ///< change of the unit baseline direction
  double direction_angle;     ///< rad
};

/// The change from the left-right extrinsic `used` (a cloud's rectification) to `now`.
RectificationChange rectificationChange(const Eigen::Isometry3d& used,
                                        const Eigen::Isometry3d& now);

/// True when stereo clouds computed with `used` should be recomputed for `now`: the rotation
/// differs by more than `tol_deg` or the baseline direction by more than `tol_direction_deg`
/// (negative: `tol_deg`); the baseline length does not matter.
bool needsRerectification(const Eigen::Isometry3d& used, const Eigen::Isometry3d& now,
                          double tol_deg, double tol_direction_deg = -1.0,
                          double tol_yaw_deg = -1.0);

/// When a window's stereo clouds follow a new left->right estimate (angles in degrees, < 0 as in
/// needsRerectification). Beyond `rot_deg` / `direction_deg` / `yaw_deg` from the estimate a
/// cloud was triangulated with, it is triangulated again; SGBM matches again only when the
/// estimate is also beyond `rematch_rot_deg` (about x and z: vertical misalignment of the images
/// SGBM saw) or `rematch_direction_deg` from the one it matched with (< 0: always).
struct RectifyTolerances {
  double rot_deg = 0.005;
  double direction_deg = -1.0;
  double yaw_deg = -1.0;
  double rematch_rot_deg = -1.0;
  double rematch_direction_deg = -1.0;
};

/// Brings the window's stereo clouds to `T_right_left` where the rectification differs enough
/// (re-triangulating or matching again, see RectifyTolerances) and rescales the others to its
/// baseline length (a rectified cloud is linear in it); returns how many it recomputed and adds
/// the time to `*seconds` (and the number matched again to `*rematched`, when given).
int rectifyWindow(const std::vector<Keyframe*>& window, const StereoRig& rig,
                  const Eigen::Isometry3d& T_right_left, const StereoSettings& settings,
                  const RectifyTolerances& tolerances, double* seconds, int* rematched = nullptr);

}  // namespace tescalib
