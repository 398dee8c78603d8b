// The checks' judgements of a LiDAR-stereo solve: widening its covariance after a check found
// more uncertainty than the solve itself measured, and judging its axes again; whether the
// split-window recheck's halves depend on their start; the wide-basin search's rival minima.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {

/// Scales `full`'s covariances by k, adds `added`, and judges the axes again; a converged solve
/// that then loses an axis, or any converged one when `refuse`, is no longer converged, and its
/// message is `why` and the weakest direction.
void widenAndJudge(double k, const Matrix6d& added, bool refuse, const std::string& why,
                   const LidarStereoSettings& settings, LidarStereoResult* full);

/// The split-window recheck (HalvesStart::kEstimateThenInitialGuess): each half solved again from
/// the initial guess against the same half solved from the estimate (their summed covariances; a
/// rechecked half counts when it converged or failed only for an unconstrained axis, not when it
/// did not settle or ended with a nuisance on its bound): the largest chi2 and its difference.
double halvesStartsApart(const LidarStereoResult from_estimate[2],
                         const LidarStereoResult rechecked[2], Vector6d* difference);

/// The wide-basin search's check of its chosen solve (`chosen`, converged) against every solve
/// it `tried` (the chosen one among them): another that settled beyond halves_chi2_limit from it
/// (chi2 with their summed covariances, 6 DoF) and fits the window about as well (a mean
/// normalised fine residual at most 1.1 times the chosen one's) is a second minimum the window does
/// not tell from the chosen one. Then the chosen solve is refused (not converged, the message
/// names both) and its covariance widened by the difference along it (the other is as likely).
void refuseBesideRivalMinimum(const std::vector<LidarStereoResult>& tried,
                              const LidarStereoSettings& settings, LidarStereoResult* chosen);

/// printf into a string (the checks' messages).
template <typename... Values>
std::string formatted(const char* format, Values... values) {
  char buf[400];
  std::snprintf(buf, sizeof buf, format, values...);
  return buf;
}

}  // namespace tescalib
