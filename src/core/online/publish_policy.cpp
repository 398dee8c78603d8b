#include "tescalib/core/online/publish_policy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// Like with like: the stereo part counts only when both estimated it. Axis by axis. The first
/// co-calibrated estimate after LiDAR-first ones has its own, looser bound: their LiDAR covariance
/// takes camera_info's stereo pair as exact, the co-calibrated one does not (its clouds' scale and
/// yaw are free), so it is wider by construction (with max_variance_growth, tescalib_calibrate
/// --mode co never publishes a co-calibrated one on generated urban drives; rz variance
/// 2.4-3.3x). And the co-calibrated LiDAR covariance carries the pair's uncertainty too, which
/// the LiDAR-first one cannot: the first co-calibrated one is compared by its LiDAR covariance
/// given the pair (online_e2e_co: rz sigma 0.046 deg with the pair's uncertainty vs 0.013 deg
/// LiDAR-first, never published).
std::string varianceGrowthRefusal(const OnlineEstimate& e, const OnlineEstimate& published,
                                  const OnlineSettings& settings) {
  const bool both = e.stereo_estimated && published.stereo_estimated;
  const bool first_co = e.stereo_estimated && !published.stereo_estimated;
  const double growth =
      first_co ? settings.max_variance_growth_first_co : settings.max_variance_growth;
  static const char* kAxes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  for (int part = 0; part < (both ? 2 : 1); ++part) {
    const Matrix6d& now = part == 1  ? e.cov_stereo
                          : first_co ? e.cov_lidar_given_stereo
                                     : e.cov_lidar;
    const Matrix6d& before = part == 0 ? published.cov_lidar : published.cov_stereo;
    for (int i = 0; i < 6; ++i)
      if (!std::isfinite(now(i, i)) || now(i, i) > growth * before(i, i)) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "new estimate is less certain than the published one (%s sigma of %s "
                      "%.3g vs %.3g, from %d vs %d keyframes): kept the old one",
                      part == 1  ? "stereo"
                      : first_co ? "LiDAR (given the pair)"
                                 : "LiDAR",
                      kAxes[i], std::sqrt(now(i, i)), std::sqrt(before(i, i)), e.keyframes_used,
                      published.keyframes_used);
        return buf;
      }
  }
  return "";
}

/// Why `e` is held back, before the change check; empty when it is published.
std::string refusalReason(const OnlineEstimate& e, const std::optional<OnlineEstimate>& published,
                          const OnlineSettings& settings, const std::string& solve_message,
                          bool recalibrating) {
  if (!e.converged)
    return "not converged (" + solve_message +
           "): " + (published ? "keeping the previous estimate" : "nothing published yet");
  // A covariance with NaN would pass every later "less certain" comparison (NaN compares false):
  // not published, the first estimate included.
  if ((e.cov_lidar_known && !e.cov_lidar.allFinite()) ||
      (e.stereo_estimated && e.cov_stereo_known && !e.cov_stereo.allFinite()))
    return "its covariance is not finite: " +
           std::string(published ? "keeping the previous estimate" : "nothing published yet");
  if (!published) return "";
  // After the window restarted (a reset of the window by a bag's loop; the estimate is kept),
  // its first solves come from a few keyframes, and their covariances hardly show it (the model
  // error's floor dominates them): wait until the window holds as many as the estimate it would
  // replace (3 keyframes replacing 10 gave rotation errors 2-3x larger).
  if (e.keyframes_used < std::min(published->keyframes_used, settings.window_size))
    return "from " + std::to_string(e.keyframes_used) +
           " keyframes, fewer than the published estimate's " +
           std::to_string(published->keyframes_used) + ": kept it until the window refills";
  // The monitor found the published extrinsic changed: its covariance says how well the old
  // rig was known and bounds nothing about the new one.
  if (recalibrating) return "";
  return varianceGrowthRefusal(e, *published, settings);
}

}  // namespace

double chi2ToPublished(const OnlineEstimate& candidate,
                       const std::optional<OnlineEstimate>& published) {
  if (!candidate.converged || !published) return std::numeric_limits<double>::quiet_NaN();
  return nees(poseError(candidate.T_cam_lidar, published->T_cam_lidar),
              candidate.cov_lidar + published->cov_lidar);
}

std::string publicationRefusal(const OnlineEstimate& candidate,
                               const std::optional<OnlineEstimate>& published,
                               const OnlineSettings& settings, const std::string& solve_message,
                               bool recalibrating) {
  std::string why = refusalReason(candidate, published, settings, solve_message, recalibrating);
  if (why.empty()) return why;
  // A converged solve kept back: does it still agree with what is published?
  if (std::isfinite(candidate.chi2_to_published)) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "; it is %.1f chi2 (6 DoF) from the published one",
                  candidate.chi2_to_published);
    why += buf;
    if (candidate.chi2_to_published > settings.changed_chi2)
      why +=
          ", more than the two covariances allow: the extrinsic may have changed since it was "
          "published (~reset recalibrates)";
  }
  return why;
}

}  // namespace tescalib
