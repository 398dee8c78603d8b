#include "tescalib/core/common/geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace tescalib {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity() + skew(phi);
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, const Vector6d& delta) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = expSO3(delta.head<3>()) * T.linear();
  out.translation() = T.translation() + delta.tail<3>();
  return out;
}

Vector6d poseError(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_gt) {
  Vector6d e;
  e.head<3>() = logSO3(T_est.linear() * T_gt.linear().transpose());
  e.tail<3>() = T_est.translation() - T_gt.translation();
  return e;
}

namespace {
Eigen::Vector3d randomUnitVector(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(n(rng), n(rng), n(rng));
  } while (v.norm() < 1e-9);
  return v.normalized();
}
}  // namespace

Vector6d randomPerturbation(double rot_rad, double trans_m, std::mt19937_64& rng) {
  Vector6d d;
  d.head<3>() = rot_rad * randomUnitVector(rng);
  d.tail<3>() = trans_m * randomUnitVector(rng);
  return d;
}

Eigen::Isometry3d isometryFrom3x4(const Eigen::Matrix<double, 3, 4>& M) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = M.leftCols<3>();
  T.translation() = M.col(3);
  return T;
}

bool isRigidTransform(const Eigen::Isometry3d& T, double tol) {
  const Eigen::Matrix3d R = T.linear();
  return T.matrix().allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < tol &&
         std::fabs(R.determinant() - 1.0) < tol;
}

std::string stereoExtrinsicProblem(const Eigen::Isometry3d& T_right_left) {
  if (!isRigidTransform(T_right_left))
    return "the left->right transform is not a rigid transform (NaN, or not a rotation)";
  if (T_right_left.translation().norm() < 1e-3)
    return "the left->right transform has no baseline (shorter than 1 mm)";
  return "";
}

}  // namespace tescalib
