// The covariance of one estimate of an alternation between two solvers, at the alternation's
// fixed point (first order; co-calibration, paper "Co-calibration" and "Uncertainty Analysis").
#pragma once

#include "tescalib/core/common/geometry.h"

namespace tescalib {

/// Estimate a solves with the other estimate b held fixed (covariance P_a|b, sensitivity
/// S_ab = d a / d b), b with a held fixed (covariance P_b, sensitivity S_ba = d b / d a), all
/// over [phi; tau] of the perturb() convention.
struct FixedPointCovariance {
  Matrix6d covariance = Matrix6d::Identity();  ///< gain (P_a|b + added) gain^T
  Matrix6d added = Matrix6d::Zero();           ///< S_ab P_b S_ab^T: b's uncertainty carried into a
  /// Spectral radius of the loop S_ab S_ba (the alternation's contraction; below 1 at a fixed
  /// point).
  double coupling = 0;
};

/// P_a = G (P_a|b + S_ab P_b S_ab^T) G^T with the fixed point's gain G = (I - S_ab S_ba)^-1: a
/// deviation of a moves b, which moves a again. Beyond `max_coupling` the first-order gain is not
/// to be trusted and G = I (the sensitivity alone).
FixedPointCovariance fixedPointCovariance(const Matrix6d& cov_a_given_b, const Matrix6d& S_ab,
                                          const Matrix6d& cov_b, const Matrix6d& S_ba,
                                          double max_coupling = 0.9);

}  // namespace tescalib
