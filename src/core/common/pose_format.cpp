#include "tescalib/core/common/pose_format.h"

#include <cmath>
#include <cstdio>

#include "tescalib/core/common/geometry.h"

namespace tescalib {

namespace {

/// `v` as printed with `digits` decimals, without the sign of a value that prints as zero
/// ("-0.0000" says nothing a reader can use).
double shown(double v, int digits) {
  return std::fabs(v) < 0.5 * std::pow(10.0, -digits) ? 0.0 : v;
}

}  // namespace

Eigen::Vector3d rollPitchYaw(const Eigen::Matrix3d& R) {
  // R = Rz(yaw) Ry(pitch) Rx(roll) has R(2,0) = -sin(pitch), R(2,1) = cos(pitch) sin(roll),
  // R(2,2) = cos(pitch) cos(roll), R(1,0) = sin(yaw) cos(pitch), R(0,0) = cos(yaw) cos(pitch).
  // atan2 rather than asin(-R(2,0)): exact near pitch +-pi/2, where asin loses half the digits.
  const double cos_pitch = std::hypot(R(2, 1), R(2, 2));
  const double pitch = std::atan2(-R(2, 0), cos_pitch);
  if (cos_pitch < 1e-9) {
    // Gimbal lock: with yaw 0, R = Ry(pitch) Rx(roll), whose middle row is [0 cos -sin](roll).
    return Eigen::Vector3d(std::atan2(-R(1, 2), R(1, 1)), pitch, 0.0);
  }
  return Eigen::Vector3d(std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0)));
}

Eigen::Matrix3d fromRollPitchYaw(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

std::string describeTransform(const std::string& parent, const std::string& child,
                              const Eigen::Isometry3d& T_parent_child, const std::string& indent) {
  Eigen::Quaterniond q(T_parent_child.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;  // q and -q are one rotation: the one with w >= 0 is shown
  const Eigen::Vector3d& t = T_parent_child.translation();
  const Eigen::Vector3d rpy = rollPitchYaw(T_parent_child.linear()) * kDegPerRad;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%s -> %s:\n"
                "%stranslation [%+.4f %+.4f %+.4f] m\n"
                "%squaternion (x y z w) [%+.6f %+.6f %+.6f %+.6f]\n"
                "%sroll/pitch/yaw [%+.4f %+.4f %+.4f] deg (R = Rz(yaw) Ry(pitch) Rx(roll), as tf)",
                parent.c_str(), child.c_str(), indent.c_str(), shown(t.x(), 4), shown(t.y(), 4),
                shown(t.z(), 4), indent.c_str(), shown(q.x(), 6), shown(q.y(), 6), shown(q.z(), 6),
                shown(q.w(), 6), indent.c_str(), shown(rpy.x(), 4), shown(rpy.y(), 4),
                shown(rpy.z(), 4));
  return buf;
}

}  // namespace tescalib
