// How the left-right estimate follows the LiDAR extrinsic that gave its key points' depth
// (PhotometricResult::lidar_sensitivity): first order, from the full-resolution photometric
// problem at its solution.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/lidar/lidar_mesh.h"
#include "tescalib/core/solvers/residuals/photometric_residual.h"

namespace tescalib {

/// A used key point's residual and the row D with d(log depth) = D d[phi; tau] of T_cam_lidar.
struct DepthLink {
  PhotometricResidual residual;
  int keyframe;
  Eigen::Matrix<double, 1, 6> D;
};

/// How the depth of the point X (left camera frame) on face `f` follows a perturbation
/// [phi; tau] of T_cam_lidar (R = Exp(phi) R, t = t + tau): the face moves by
/// phi x (X - t) + tau, along its normal n by n.(...), and the ray's depth by that over n.X
/// (relative: d log Z = (phi.((X - t) x n) + tau.n) / n.X).
Eigen::Matrix<double, 1, 6> depthRow(const MeshFace& f, const Eigen::Isometry3d& T_cam_lidar,
                                     const Eigen::Vector3d& X);

/// First-order sensitivity of the solution to the LiDAR extrinsic (implicit function theorem on
/// the Gauss-Newton normal equations with the Huber weights at the solution):
///   d x / d xi = -H^-1 sum_i w_i J_x,i^T J_rho,i D_i,   H = sum_i w_i J_x,i^T J_x,i (+ prior),
/// x = [delta; per-keyframe (a, b)], rho = a key point's log depth; the pose rows are returned.
/// `fixed_length_at`: the solution, when the stiff baseline-length prior was part of the problem.
Matrix6d lidarSensitivity(const std::vector<DepthLink>& links, const double* delta,
                          const std::vector<std::array<double, 2>>& ab, double huber,
                          const Eigen::Isometry3d* fixed_length_at);

}  // namespace tescalib
