#include "calibrate_split.h"

#include <cstdio>

#include <Eigen/Cholesky>

#include "calibrate_print.h"
#include "tescalib/core/common/geometry.h"

namespace tescalib::calibrate {

double pairChi2(const OnlineEstimate& a, const OnlineEstimate& b) {
  if (!a.cov_lidar_known || !b.cov_lidar_known) return -1;
  const Vector6d d = poseError(a.T_cam_lidar, b.T_cam_lidar);
  const Eigen::LLT<Matrix6d> llt(a.cov_lidar + b.cov_lidar);
  if (llt.info() != Eigen::Success) return -1;
  return d.dot(llt.solve(d));
}

void printRepeatability(const std::vector<SplitWindow>& windows) {
  std::printf("\nrepeatability: %zu disjoint windows\n", windows.size());
  for (size_t i = 0; i < windows.size(); ++i) {
    const SplitWindow& w = windows[i];
    std::printf("  window %zu (keyframes %s): %s\n", i + 1, w.keyframes.c_str(),
                !w.solved     ? "no solve"
                : w.converged ? "converged"
                              : "not converged (its last solve)");
  }
  double sum = 0;
  int pairs = 0, above = 0;
  for (size_t i = 0; i < windows.size(); ++i)
    for (size_t j = i + 1; j < windows.size(); ++j) {
      if (!windows[i].solved || !windows[j].solved) continue;
      const OnlineEstimate& a = windows[i].estimate;
      const OnlineEstimate& b = windows[j].estimate;
      const double chi2 = pairChi2(a, b);
      std::printf("  windows %zu - %zu: %s", i + 1, j + 1,
                  pose6(poseError(a.T_cam_lidar, b.T_cam_lidar)).c_str());
      if (chi2 < 0) {
        std::printf(", chi2 unknown (a covariance is missing)\n");
        continue;
      }
      std::printf(", chi2 %.1f%s\n", chi2,
                  chi2 > 12.59 ? " (above 12.59: the covariances do not "
                                 "cover the difference)"
                               : "");
      sum += chi2;
      ++pairs;
      above += chi2 > 12.59;
    }
  if (pairs > 0)
    std::printf("  mean chi2 %.1f over %d pairs (6 DoF: ideal 6), %d above 12.59 (95 %%)\n",
                sum / pairs, pairs, above);
  else
    std::printf("  no pair of windows with estimates and covariances\n");
}

}  // namespace tescalib::calibrate
