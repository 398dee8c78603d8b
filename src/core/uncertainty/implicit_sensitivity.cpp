#include "tescalib/core/uncertainty/implicit_sensitivity.h"

#include <cmath>

#include <Eigen/Cholesky>

namespace tescalib {

double huberWeight(double squared_norm, double huber) {
  return squared_norm <= huber * huber ? 1.0 : huber / std::sqrt(squared_norm);
}

Eigen::MatrixXd implicitSensitivity(const Eigen::MatrixXd& H, const Eigen::MatrixXd& B, int rows) {
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success) return Eigen::MatrixXd::Zero(rows, B.cols());
  const Eigen::MatrixXd S = -ldlt.solve(B);
  if (!S.allFinite()) return Eigen::MatrixXd::Zero(rows, B.cols());
  return S.topRows(rows);
}

}  // namespace tescalib
