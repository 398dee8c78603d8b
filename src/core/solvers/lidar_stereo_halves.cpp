// The split-window check of the LiDAR-stereo calibration's noise model
// (LidarStereoSettings::check_window_halves): the window's two halves solved on their own must
// agree within their covariances.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

void printHalves(double chi2, const Vector6d& e, const LidarStereoResult& a,
                 const LidarStereoResult& b) {
  std::fprintf(stderr,
               "window halves: chi2 %.1f, difference rot [%.4f %.4f %.4f] deg, "
               "t [%.2f %.2f %.2f] cm\n",
               chi2, e[0] * kDegPerRad, e[1] * kDegPerRad, e[2] * kDegPerRad, e[3] * 100,
               e[4] * 100, e[5] * 100);
  for (const LidarStereoResult* h : {&a, &b}) {
    const Vector6d sd = h->covariance.diagonal().cwiseSqrt();
    std::fprintf(stderr,
                 "  half: settled %d, %d iterations, sigma rot [%.4f %.4f %.4f] deg, "
                 "t [%.2f %.2f %.2f] cm\n",
                 h->settled, h->iterations, sd[0] * kDegPerRad, sd[1] * kDegPerRad,
                 sd[2] * kDegPerRad, sd[3] * 100, sd[4] * 100, sd[5] * 100);
  }
}

}  // namespace

bool windowHalvesDue(const LidarStereoResult& r, const LidarStereoSettings& s) {
  if (!s.check_window_halves || s.cancelled()) return false;
  return r.converged || (s.halves_when_unsettled && !r.settled && r.fine_inliers >= s.min_inliers);
}

void checkWindowHalves(const std::vector<const Keyframe*>& window, const LidarStereoSettings& s,
                       LidarStereoResult* full) {
  const auto t0 = std::chrono::steady_clock::now();
  full->halves = LidarStereoResult::Halves();
  const size_t half = window.size() / 2;
  if (s.min_keyframes_per_half < 1 || half < static_cast<size_t>(s.min_keyframes_per_half)) return;
  LidarStereoSettings hs = s;
  hs.run_coarse = false;
  hs.check_window_halves = false;
  hs.initial_stereo_yaw_rad = full->stereo_yaw_rad;
  hs.initial_stereo_scale = full->stereo_scale;
  // A half constrains less than the window: its fine stage may need longer to settle.
  hs.fine_reassociations = 2 * s.fine_reassociations;
  const std::vector<const Keyframe*> first(window.begin(), window.begin() + half),
      second(window.begin() + half, window.end());
  // The two halves are independent solves: side by side.
  LidarStereoResult halves[2];
  parallelFor(2, s.threads, [&](int h) {
    halves[h] = solveLidarStereo(h == 0 ? first : second, full->T_cam_lidar, hs);
  });
  const LidarStereoResult& a = halves[0];
  const LidarStereoResult& b = halves[1];
  full->halves.seconds = secondsSince(t0);
  // Only halves with a covariance are compared (a cancelled or failed half returns its start and
  // a placeholder, which would pass as agreement).
  for (const LidarStereoResult* r : {&a, &b})
    if (r->fine_inliers < s.min_inliers || !r->covariance_known || s.cancelled()) return;
  const Vector6d e = poseError(a.T_cam_lidar, b.T_cam_lidar);
  const Matrix6d S = a.covariance + b.covariance;
  const double chi2 = e.dot(S.ldlt().solve(e));
  if (!std::isfinite(chi2)) return;
  if (std::getenv("TESCALIB_DEBUG")) printHalves(chi2, e, a, b);
  full->halves.tested = true;
  full->halves.chi2 = chi2;
  full->halves.difference = e;
  full->halves.second_T = b.T_cam_lidar;
  full->halves.second_covariance = b.covariance;
  full->halves.second_settled = b.settled;
  full->halves.second_trusted = b.converged;
  full->halves.second_begin = half;
  if (chi2 <= s.halves_chi2_limit) return;
  // The halves disagree beyond what the covariances allow: the data hold an error the model
  // does not know (on real KITTI, sequences of one day differ by 3-6 sigma). Scale the
  // covariances by the observed disagreement (chi2 / DoF), add the disagreement itself along its
  // own direction (the spread of two estimates e apart about their mean: e e^T / 4; a generated
  // highway's halves 0.3 deg / 47 cm off the truth disagree mostly along it) and judge the axes
  // again.
  const double k = chi2 / 6.0;
  full->halves.covariance_scale = k;
  const Matrix6d spread = 0.25 * e * e.transpose();
  const Matrix6d constrained = k * constrainedCovariance(*full, s) + spread;
  full->covariance = k * full->covariance + spread;
  full->covariance_statistical = k * full->covariance_statistical + spread;
  full->stereo_scale_variance *= k;
  full->weak_directions = weakDirections(constrained, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  if (!trustFlags(constrained, s, full->observable) && full->converged) {
    full->converged = false;
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the window's two halves disagree (chi2 %.1f > %.1f, 6 DoF): covariance scaled "
                  "by %.1f and widened along their difference, and then the window does not "
                  "constrain every axis",
                  chi2, s.halves_chi2_limit, k);
    full->message = buf + weakestClause(full->weak_directions);
  }
}

}  // namespace tescalib
