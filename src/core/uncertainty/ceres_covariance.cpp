#include "tescalib/core/uncertainty/ceres_covariance.h"

#include <utility>

namespace tescalib {

bool blockCovariances(ceres::Problem* problem, const std::vector<const double*>& blocks,
                      const ceres::Covariance::Options& options,
                      std::vector<RowMajorMatrixXd>* covariances) {
  ceres::Covariance cov(options);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (const double* b : blocks) pairs.emplace_back(b, b);
  if (!cov.Compute(pairs, problem)) return false;
  covariances->clear();
  for (const double* b : blocks) {
    const int n = problem->ParameterBlockTangentSize(b);
    RowMajorMatrixXd C(n, n);
    cov.GetCovarianceBlockInTangentSpace(b, b, C.data());
    covariances->push_back(std::move(C));
  }
  return true;
}

double residualVariance(double final_cost, int residuals, int parameters) {
  return 2.0 * final_cost / std::max(1, residuals - parameters);
}

}  // namespace tescalib
