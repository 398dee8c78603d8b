// tescalib_calibrate --split K: the estimates of K disjoint windows of one recording against each
// other, each pair's difference judged by their covariances (chi2 over 6 DoF): repeatability.
#pragma once

#include <string>
#include <vector>

#include "tescalib/core/online/online_estimate.h"

namespace tescalib::calibrate {

/// One window's result: its estimate (converged or not) and the keyframes it was fed.
struct SplitWindow {
  std::string keyframes;  ///< "1-8" (numbers of the recording's keyframes, from 1)
  bool solved = false;    ///< a solve gave a result
  bool converged = false;
  OnlineEstimate estimate;
};

/// d^T (P_a + P_b)^-1 d for the difference d of two T_cam_lidar over [phi; tau]; -1 when either
/// covariance is unknown or their sum is not positive definite.
double pairChi2(const OnlineEstimate& a, const OnlineEstimate& b);

/// Prints the windows' estimates and every pair's difference with its chi2 (6 DoF: 95 % of pairs
/// below 12.59 when the covariances tell the truth), and the mean chi2 (ideal 6).
void printRepeatability(const std::vector<SplitWindow>& windows);

}  // namespace tescalib::calibrate
