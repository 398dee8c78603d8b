// Covariance of a robust least-squares estimate from its Gauss-Newton information and its
// residuals' scores: the paper's eq. residual_uncertainty (H^-1, residuals already divided by
// their noise-model sigma, i.e. weighted by (J_w Sigma J_w^T)^-1) assumes independent residuals;
// the cluster-robust sandwich H^-1 (sum_c g_c g_c^T) H^-1 lets the residuals of one cluster
// share their errors (neighbouring stereo points share matching and association errors).
#pragma once

#include <vector>

#include <Eigen/Core>

namespace tescalib {

/// Whether an information matrix can be inverted for a covariance: its smallest eigenvalue is
/// above 1e-12 times its largest (or 1e-12, when the largest is below 1).
bool informationInvertible(const Eigen::MatrixXd& information);

/// The sandwich's middle: sum_c g_c g_c^T over the clusters with a nonzero score g_c
/// (sum_{i in c} w_i J_i^T r_i), times C / (C - 1) for C > 1 such clusters (the small-sample
/// correction). `n`: the parameters.
Eigen::MatrixXd clusterScoreOuterSum(const std::vector<Eigen::VectorXd>& scores, int n);

/// The cluster-robust covariance H^-1 M H^-1 (M = clusterScoreOuterSum, symmetrised), or, when
/// one of its first `floored_parameters` variances is below the model's scaled by the residuals'
/// own spread, residual_scale^2 H^-1: never more confident than the paper's covariance with the
/// residuals' robust variance. `information_inverse` is H^-1 over all parameters.
Eigen::MatrixXd clusterRobustCovariance(const Eigen::MatrixXd& information_inverse,
                                        const std::vector<Eigen::VectorXd>& scores,
                                        double residual_scale, int floored_parameters);

/// The two-way cluster-robust covariance (Cameron, Gelbach and Miller, "Robust inference with
/// multiway clustering", 2011): residuals share errors within a cluster of either kind `a` or `b`
/// (image cells, which share matching errors, and LiDAR rings, which share one laser's range and
/// elevation error in every keyframe). H^-1 (M_a + M_b - M_ab) H^-1, M_ab over the clusters of
/// both kinds at once (the residuals in one cell and ring), with the negative eigenvalues the
/// difference can leave set to zero, and floored as clusterRobustCovariance.
Eigen::MatrixXd twoWayClusterCovariance(const Eigen::MatrixXd& information_inverse,
                                        const std::vector<Eigen::VectorXd>& scores_a,
                                        const std::vector<Eigen::VectorXd>& scores_b,
                                        const std::vector<Eigen::VectorXd>& scores_ab,
                                        double residual_scale, int floored_parameters);

}  // namespace tescalib
