#include "tescalib/core/uncertainty/common_bias.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "tescalib/core/uncertainty/sandwich_covariance.h"

namespace tescalib {

Eigen::MatrixXd biasSensitivity(const Eigen::MatrixXd& H_inv, const Eigen::MatrixXd& jtd) {
  return -(H_inv * jtd);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> heldBiasSensitivity(const Eigen::MatrixXd& H,
                                                             const Eigen::MatrixXd& jtd) {
  return -(H.topLeftCorner<6, 6>().ldlt().solve(jtd.topRows<6>()));
}

Matrix6d withCommonBiases(const Matrix6d& covariance,
                          const Eigen::Matrix<double, 6, Eigen::Dynamic>& h,
                          const std::vector<double>& sigmas) {
  Matrix6d c = covariance;
  for (size_t j = 0; j < sigmas.size(); ++j)
    c += std::pow(sigmas[j], 2) * h.col(j) * h.col(j).transpose();
  return c;
}

CommonOffset estimateCommonOffset(const Eigen::MatrixXd& H,
                                  const std::vector<Eigen::VectorXd>& scores,
                                  const Eigen::VectorXd& jtd, double dtd,
                                  const std::vector<double>& offset_scores, double residual_scale) {
  const int n = static_cast<int>(H.rows());
  Eigen::MatrixXd Ha(n + 1, n + 1);
  Ha << H, jtd, jtd.transpose(), dtd;
  Eigen::VectorXd ga = Eigen::VectorXd::Zero(n + 1);
  Eigen::MatrixXd Ma = Eigen::MatrixXd::Zero(n + 1, n + 1);
  Eigen::VectorXd gc(n + 1);
  int used = 0;
  for (size_t c = 0; c < scores.size(); ++c) {
    gc << scores[c], offset_scores[c];
    if (gc.squaredNorm() == 0) continue;
    ga += gc;
    Ma += gc * gc.transpose();
    ++used;
  }
  CommonOffset offset;
  if (used <= 1 || !informationInvertible(Ha)) return offset;
  Ma *= double(used) / double(used - 1);
  const Eigen::MatrixXd Ha_inv = Ha.inverse();
  offset.measured = true;
  offset.value = -(Ha_inv * ga)(n);
  const double k2 = residual_scale * residual_scale;
  offset.sigma = std::sqrt(std::max((Ha_inv * Ma * Ha_inv)(n, n), k2 * Ha_inv(n, n)));
  return offset;
}

}  // namespace tescalib
