// Extrinsics in the words users read them in: a named parent -> child transform as ROS tf
// publishes it, its translation in m and its rotation as a quaternion and as roll/pitch/yaw in
// deg.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tescalib {

/// Roll, pitch and yaw (rad) of R = Rz(yaw) Ry(pitch) Rx(roll): roll about the parent's x, then
/// pitch about its y, then yaw about its z (fixed axes, as ROS tf's getRPY and URDF's rpy).
/// Pitch lies in [-pi/2, pi/2]; at pitch +-pi/2, where only roll - yaw or roll + yaw is defined,
/// yaw is 0.
Eigen::Vector3d rollPitchYaw(const Eigen::Matrix3d& R);

/// The rotation of roll, pitch and yaw (rad): Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d fromRollPitchYaw(const Eigen::Vector3d& rpy);

/// The transform T_parent_child (it maps child points into the parent frame, as a tf from
/// `parent` to `child`) in three lines, each starting with `indent`:
///   parent -> child:
///     translation [x y z] m
///     quaternion (x y z w) [qx qy qz qw]   (w >= 0)
///     roll/pitch/yaw [r p y] deg (R = Rz(yaw) Ry(pitch) Rx(roll), as tf)
/// The first line carries no indent, so that a caller can put a name before it.
std::string describeTransform(const std::string& parent, const std::string& child,
                              const Eigen::Isometry3d& T_parent_child,
                              const std::string& indent = "  ");

}  // namespace tescalib
