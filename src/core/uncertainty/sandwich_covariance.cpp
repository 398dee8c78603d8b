#include "tescalib/core/uncertainty/sandwich_covariance.h"

#include <algorithm>

#include <Eigen/Eigenvalues>

namespace tescalib {

bool informationInvertible(const Eigen::MatrixXd& H) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  return eig.eigenvalues().minCoeff() > 1e-12 * std::max(1.0, eig.eigenvalues().maxCoeff());
}

Eigen::MatrixXd clusterScoreOuterSum(const std::vector<Eigen::VectorXd>& scores, int n) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  int used = 0;
  for (const Eigen::VectorXd& g : scores)
    if (g.squaredNorm() > 0) M += g * g.transpose(), ++used;
  if (used > 1) M *= double(used) / double(used - 1);  // small-sample correction
  return M;
}

namespace {

/// The symmetrised sandwich H^-1 M H^-1, or residual_scale^2 H^-1 where one of its first
/// `floored_parameters` variances is below that.
Eigen::MatrixXd flooredSandwich(const Eigen::MatrixXd& H_inv, const Eigen::MatrixXd& M,
                                double residual_scale, int floored_parameters) {
  const Eigen::MatrixXd sandwich = H_inv * M * H_inv;
  Eigen::MatrixXd covariance = 0.5 * (sandwich + sandwich.transpose());
  const double k2 = residual_scale * residual_scale;
  for (int i = 0; i < floored_parameters; ++i)
    if (!(covariance(i, i) >= k2 * H_inv(i, i))) return k2 * H_inv;
  return covariance;
}

}  // namespace

Eigen::MatrixXd clusterRobustCovariance(const Eigen::MatrixXd& H_inv,
                                        const std::vector<Eigen::VectorXd>& scores,
                                        double residual_scale, int floored_parameters) {
  const Eigen::MatrixXd M = clusterScoreOuterSum(scores, static_cast<int>(H_inv.rows()));
  return flooredSandwich(H_inv, M, residual_scale, floored_parameters);
}

Eigen::MatrixXd twoWayClusterCovariance(const Eigen::MatrixXd& H_inv,
                                        const std::vector<Eigen::VectorXd>& scores_a,
                                        const std::vector<Eigen::VectorXd>& scores_b,
                                        const std::vector<Eigen::VectorXd>& scores_ab,
                                        double residual_scale, int floored_parameters) {
  const int n = static_cast<int>(H_inv.rows());
  const Eigen::MatrixXd M = clusterScoreOuterSum(scores_a, n) + clusterScoreOuterSum(scores_b, n) -
                            clusterScoreOuterSum(scores_ab, n);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (M + M.transpose()));
  const Eigen::VectorXd clipped = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::MatrixXd M_psd =
      eig.eigenvectors() * clipped.asDiagonal() * eig.eigenvectors().transpose();
  return flooredSandwich(H_inv, M_psd, residual_scale, floored_parameters);
}

}  // namespace tescalib
