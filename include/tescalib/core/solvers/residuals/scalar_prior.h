// A zero-mean Gaussian prior on one scalar parameter: r = x / sigma (a key point's log-depth
// correction, a LiDAR ring's range offset).
#pragma once

#include <ceres/ceres.h>

namespace tescalib {

struct ScalarPrior {
  explicit ScalarPrior(double sigma) : inv_sigma_(1.0 / sigma) {}

  template <typename T>
  bool operator()(const T* const x, T* residual) const {
    residual[0] = x[0] * T(inv_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(double sigma) {
    return new ceres::AutoDiffCostFunction<ScalarPrior, 1, 1>(new ScalarPrior(sigma));
  }

 private:
  double inv_sigma_;
};

}  // namespace tescalib
