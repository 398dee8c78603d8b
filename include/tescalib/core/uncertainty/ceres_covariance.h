// The covariance of a solved Ceres problem's parameter blocks: Ceres' estimate (J^T J)^-1, which
// assumes unit residual variance, and the residuals' own variance to scale it by.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace tescalib {

using RowMajorMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The covariance of each block of `blocks` (parameter blocks of the solved `problem`) with
/// itself, in the block's tangent space, as ceres::Covariance computes it with `options` (unit
/// residual variance). False, `covariances` left as they were, when Ceres cannot compute it (a
/// rank-deficient problem with null_space_rank 0, ...).
bool blockCovariances(ceres::Problem* problem, const std::vector<const double*>& blocks,
                      const ceres::Covariance::Options& options,
                      std::vector<RowMajorMatrixXd>* covariances);

/// The residuals' variance at a solution, 2 cost / (residuals - parameters) (Ceres' cost is half
/// the squared norm), with at least one degree of freedom.
double residualVariance(double final_cost, int residuals, int parameters);

/// The largest 1-sigma of a covariance: the square root of its largest eigenvalue (0 when that
/// is negative).
template <int N>
double largestSigma(const Eigen::Matrix<double, N, N>& covariance) {
  return std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(covariance)
                        .eigenvalues()
                        .maxCoeff()));
}

}  // namespace tescalib
