// Errors common to a whole window, which no residual statistic sees (every stereo point's
// disparity shifted by one offset, every LiDAR range by one offset): how they move an estimate
// over a 6-DoF pose [phi; tau] and nuisance parameters, and what they add to its covariance.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tescalib/core/common/geometry.h"

namespace tescalib {

/// How common biases move every parameter (one column per bias, per unit of bias), the
/// parameters solved together: -H^-1 J^T W D, `jtd` = sum_i w_i J_i^T dr_i/db (one column per
/// bias), `information_inverse` = H^-1.
Eigen::MatrixXd biasSensitivity(const Eigen::MatrixXd& information_inverse,
                                const Eigen::MatrixXd& jtd);

/// The same for the pose (the first 6 parameters) with the other parameters held at their
/// estimates: -H_pp^-1 (J^T W D)_p, `information` = H.
Eigen::Matrix<double, 6, Eigen::Dynamic> heldBiasSensitivity(const Eigen::MatrixXd& information,
                                                             const Eigen::MatrixXd& jtd);

/// `covariance` plus sigma_j^2 h_j h_j^T for each common bias j (h_j the column j of
/// `sensitivity`, sigma_j its 1-sigma size).
Matrix6d withCommonBiases(const Matrix6d& covariance,
                          const Eigen::Matrix<double, 6, Eigen::Dynamic>& sensitivity,
                          const std::vector<double>& sigmas);

/// A common offset measured from the residuals (see estimateCommonOffset).
struct CommonOffset {
  bool measured = false;  ///< false: too few clusters, or the problem with it is singular
  double value = 0;       ///< the offset that best explains the residuals
  double sigma = 0;       ///< its cluster-robust sigma
};

/// The common offset b the residuals show: one Gauss-Newton step of the problem with b added as
/// a parameter, from the estimate (b = 0), the other parameters re-solved with it, and its
/// cluster-robust sigma (the sandwich of clusterRobustCovariance, never below
/// residual_scale^2 times the model's). `information` H and `scores` (per cluster
/// sum w J^T r) over the parameters, `jtd` = sum w J^T D and `dtd` = sum w D^2 with
/// D = dr / db, `offset_scores` per cluster sum w r D.
CommonOffset estimateCommonOffset(const Eigen::MatrixXd& information,
                                  const std::vector<Eigen::VectorXd>& scores,
                                  const Eigen::VectorXd& jtd, double dtd,
                                  const std::vector<double>& offset_scores, double residual_scale);

}  // namespace tescalib
