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

Eigen::MatrixXd clusterRobustCovariance(const Eigen::MatrixXd& H_inv,
                                        const std::vector<Eigen::VectorXd>& scores,
                                        double residual_scale, int floored_parameters) {
  const Eigen::MatrixXd M = clusterScoreOuterSum(scores, static_cast<int>(H_inv.rows()));
  const Eigen::MatrixXd sandwich = H_inv * M * H_inv;
  Eigen::MatrixXd covariance = 0.5 * (sandwich + sandwich.transpose());
  const double k2 = residual_scale * residual_scale;
  for (int i = 0; i < floored_parameters; ++i)
    if (!(covariance(i, i) >= k2 * H_inv(i, i))) return k2 * H_inv;
  return covariance;
}

}  // namespace tescalib
