#include "tescalib/core/solvers/photometric_lidar_sensitivity.h"

#include <cmath>
#include <memory>

#include "tescalib/core/solvers/residuals/baseline_length_prior.h"
#include "tescalib/core/uncertainty/implicit_sensitivity.h"

namespace tescalib {

Eigen::Matrix<double, 1, 6> depthRow(const MeshFace& f, const Eigen::Isometry3d& T_cam_lidar,
                                     const Eigen::Vector3d& X) {
  const Eigen::Vector3d n =
      T_cam_lidar.linear() * (f.b - f.a).cross(f.c - f.a).cast<double>().normalized();
  const double nx = n.dot(X);
  Eigen::Matrix<double, 1, 6> D = Eigen::Matrix<double, 1, 6>::Zero();
  if (std::fabs(nx) < 1e-9) return D;
  D.head<3>() = (X - T_cam_lidar.translation()).cross(n).transpose() / nx;
  D.tail<3>() = n.transpose() / nx;
  return D;
}

Matrix6d lidarSensitivity(const std::vector<DepthLink>& links, const double* delta,
                          const std::vector<std::array<double, 2>>& ab, double huber,
                          const Eigen::Isometry3d* fixed_length_at) {
  const int n = 6 + 2 * static_cast<int>(ab.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n), B = Eigen::MatrixXd::Zero(n, 6);
  double r[kPatternSize], jd[kPatternSize * 6], jab[kPatternSize * 2], jr[kPatternSize];
  const double rho0 = 0.0;
  for (const DepthLink& l : links) {
    std::unique_ptr<ceres::CostFunction> cost(PhotometricDepthResidual::Create(l.residual));
    const double* params[3] = {delta, ab[l.keyframe].data(), &rho0};
    double* jac[3] = {jd, jab, jr};
    if (!cost->Evaluate(params, r, jac)) continue;
    double s2 = 0;
    for (double x : r) s2 += x * x;
    const double w = huberWeight(s2, huber);
    // The residual depends on the pose and its keyframe's (a, b) only: columns 0-5 and c, c + 1.
    Eigen::Matrix<double, kPatternSize, 8> J;
    for (int p = 0; p < kPatternSize; ++p) {
      for (int j = 0; j < 6; ++j) J(p, j) = jd[p * 6 + j];
      J(p, 6) = jab[p * 2], J(p, 7) = jab[p * 2 + 1];
    }
    const Eigen::Map<const Eigen::Matrix<double, kPatternSize, 1>> Jr(jr);
    const Eigen::Matrix<double, 8, 8> h = w * J.transpose() * J;
    const Eigen::Matrix<double, 8, 6> b = w * (J.transpose() * Jr) * l.D;
    const int c = 6 + 2 * l.keyframe;
    H.topLeftCorner<6, 6>() += h.topLeftCorner<6, 6>();
    H.block<6, 2>(0, c) += h.topRightCorner<6, 2>();
    H.block<2, 6>(c, 0) += h.bottomLeftCorner<2, 6>();
    H.block<2, 2>(c, c) += h.bottomRightCorner<2, 2>();
    B.topRows<6>() += b.topRows<6>();
    B.middleRows<2>(c) += b.bottomRows<2>();
  }
  if (fixed_length_at) {  // the stiff length prior (BaselineLengthPrior) at the solution
    const Eigen::Vector3d t = fixed_length_at->translation();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    g.segment<3>(3) = kBaselineLengthWeight * t.normalized();
    H += g * g.transpose();
  }
  return implicitSensitivity(H, B, 6);
}

}  // namespace tescalib
