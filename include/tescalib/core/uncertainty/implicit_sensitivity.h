// First-order sensitivity of a least-squares solution to quantities it holds fixed (implicit
// function theorem on the Gauss-Newton normal equations at the solution).
#pragma once

#include <Eigen/Core>

namespace tescalib {

/// The weight a Huber loss of scale `huber` gives a residual block of squared norm
/// `squared_norm` in the Gauss-Newton normal equations (iteratively reweighted least squares):
/// 1 inside the quadratic region, huber / |r| beyond it.
double huberWeight(double squared_norm, double huber);

/// dx/dp = -H^-1 B for a solution x of normal equations with information H (n x n) and cross term
/// B = sum_i w_i J_x,i^T J_p,i (n x m) towards fixed quantities p; its first `rows` rows. Zero when
/// H cannot be factorised or the result is not finite.
Eigen::MatrixXd implicitSensitivity(const Eigen::MatrixXd& H, const Eigen::MatrixXd& B, int rows);

}  // namespace tescalib
