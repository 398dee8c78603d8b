#include "tescalib/core/uncertainty/fixed_point_covariance.h"

#include <Eigen/Eigenvalues>

namespace tescalib {

FixedPointCovariance fixedPointCovariance(const Matrix6d& cov_a_given_b, const Matrix6d& S_ab,
                                          const Matrix6d& cov_b, const Matrix6d& S_ba,
                                          double max_coupling) {
  FixedPointCovariance out;
  const Matrix6d loop = S_ab * S_ba;
  out.coupling = loop.eigenvalues().cwiseAbs().maxCoeff();
  const Matrix6d gain = out.coupling < max_coupling
                            ? Matrix6d((Matrix6d::Identity() - loop).inverse())
                            : Matrix6d::Identity();
  out.added = S_ab * cov_b * S_ab.transpose();
  out.covariance = gain * (cov_a_given_b + out.added) * gain.transpose();
  return out;
}

}  // namespace tescalib
