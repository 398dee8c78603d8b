// tescalib_calibrate's printouts of an extrinsic: the transform as the node publishes it on tf
// (parent -> child, translation in m, quaternion and roll/pitch/yaw in deg), its sigma, and one
// line on whether it is trusted.
#pragma once

#include <string>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib::calibrate {

/// "[rx ry rz] deg, [tx ty tz] cm" of a 6-vector [phi (rad); tau (m)] (an error or a change in
/// the perturbation model: rotation about and translation along the target frame's axes).
std::string pose6(const Vector6d& v);

/// An extrinsic T_a_b (it maps points from frame b into frame a, as T_cam_lidar) with what the
/// solve says of it.
struct ExtrinsicReport {
  const char* title;        ///< "LiDAR -> left camera"
  std::string parent;       ///< the tf parent: frame b (the LiDAR frame for T_cam_lidar)
  std::string child;        ///< the tf child: frame a (the left camera for T_cam_lidar)
  Eigen::Isometry3d T_a_b;  ///< T_cam_lidar or T_right_left
  Matrix6d cov;             ///< over [phi; tau] of T_a_b: about and along frame a's axes
  bool covariance_known = true;
  const bool* observable = nullptr;  ///< rx..tz within the trust limits
  bool published = true;             ///< false: the last solve's result, shown for a look
  double limit_rot_deg = 0, limit_trans_m = 0;  ///< the solver's trust limits (1 sigma)
  WeakDirection weakest = {};
  /// The node's parameter that takes T_a_b as [x, y, z, qx, qy, qz, qw] (printed in that form, a
  /// ready initial guess: the tf line above is its inverse); nullptr: none.
  const char* node_parameter = nullptr;
};

/// The transform (tf direction: parent -> child = T_a_b's inverse), T_a_b as the node's parameter
/// takes it (ExtrinsicReport::node_parameter), its sigma, the trust line and the weakest direction.
void printExtrinsic(const ExtrinsicReport& r);

/// "trusted: yes, every axis within 0.1 deg and 1 cm (1 sigma)" or "trusted: no - ..." saying
/// why.
std::string trustLine(const ExtrinsicReport& r);

}  // namespace tescalib::calibrate
