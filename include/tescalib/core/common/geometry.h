// SO(3)/SE(3) helpers and the project's one perturbation model (doc/method.md, "Conventions"):
//   R = Exp(phi) * R_ref,  t = t_ref + tau,  phi and tau in the target frame.
#pragma once

#include <array>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tescalib {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix [v]x.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

/// Rotation vector -> rotation matrix (Rodrigues).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi);

/// Rotation matrix -> rotation vector, |phi| <= pi.
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);

/// Applies the perturbation [phi; tau] to T: R = Exp(phi) R, t = t + tau.
Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, const Vector6d& delta);

/// Error of an estimate against ground truth in the same model: [Log(R_est R_gt^T); t_est - t_gt].
Vector6d poseError(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_gt);

/// A perturbation whose rotation has exactly `rot_rad` about a uniformly random axis and whose
/// translation has exactly `trans_m` in a uniformly random direction.
Vector6d randomPerturbation(double rot_rad, double trans_m, std::mt19937_64& rng);

/// Builds an isometry from a row-major 3x4 matrix [R | t].
Eigen::Isometry3d isometryFrom3x4(const Eigen::Matrix<double, 3, 4>& M);

constexpr double kDegPerRad = 57.29577951308232;

/// Whether T is a rigid transform a solver can start from: finite, its linear part a rotation
/// (orthonormal, determinant 1, to `tol`).
bool isRigidTransform(const Eigen::Isometry3d& T, double tol = 1e-6);

/// Why the pair's left->right transform cannot be a stereo extrinsic ("" when it can): not
/// rigid, or a baseline shorter than 1 mm (zero).
std::string stereoExtrinsicProblem(const Eigen::Isometry3d& T_right_left);

}  // namespace tescalib
