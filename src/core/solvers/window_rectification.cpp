#include "tescalib/core/solvers/window_rectification.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"

namespace tescalib {

RectificationChange rectificationChange(const Eigen::Isometry3d& used,
                                        const Eigen::Isometry3d& now) {
  const Eigen::Vector3d a = used.translation().normalized(), b = now.translation().normalized();
  return {logSO3(now.linear() * used.linear().transpose()), b - a,
          std::atan2(a.cross(b).norm(), a.dot(b))};
}

bool needsRerectification(const Eigen::Isometry3d& used, const Eigen::Isometry3d& now,
                          double tol_deg, double tol_direction_deg, double tol_yaw_deg) {
  const RectificationChange c = rectificationChange(used, now);
  const double rot = tol_yaw_deg < 0 ? c.phi.norm() : std::hypot(c.phi.x(), c.phi.z());
  if (tol_yaw_deg >= 0 && std::fabs(c.phi.y()) * kDegPerRad > tol_yaw_deg) return true;
  return rot * kDegPerRad > tol_deg ||
         c.direction_angle * kDegPerRad > (tol_direction_deg < 0 ? tol_deg : tol_direction_deg);
}

namespace {
/// Scales a rectified cloud to another baseline length (Z = f b / d is linear in it).
void rescaleStereo(Keyframe* kf, double baseline) {
  const double used = kf->T_right_left_used.translation().norm();
  const float k = static_cast<float>(baseline / used);
  for (StereoPoint& p : kf->stereo.points) p.p *= k;
  kf->stereo.baseline *= k;
  kf->T_right_left_used.translation() *= baseline / used;
}
}  // namespace

int rectifyWindow(const std::vector<Keyframe*>& window, const StereoRig& rig,
                  const Eigen::Isometry3d& T_right_left, const StereoSettings& settings,
                  const RectifyTolerances& tol, double* seconds, int* rematched) {
  if (window.empty()) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  // What each keyframe needs, decided first; the clouds are then computed in parallel (each
  // keyframe writes only its own).
  enum Work { kKeep, kRetriangulate, kRematch };
  std::vector<Work> work(window.size(), kKeep);
  for (size_t k = 0; k < window.size(); ++k) {
    const Keyframe* kf = window[k];
    // The yaw does not change what SGBM matches (only the disparity offset): not a reason to
    // match again. Matches made too far from the estimate are redone even when the cloud was
    // re-triangulated close to it, so that the final clouds come from matches near the estimate.
    const bool needed = kf->stereo.points.empty() ||
                        needsRerectification(kf->T_right_left_used, T_right_left, tol.rot_deg,
                                             tol.direction_deg, tol.yaw_deg);
    const bool matches_off =
        tol.rematch_rot_deg >= 0 && !kf->stereo_matched.disparity.empty() &&
        needsRerectification(kf->T_right_left_matched, T_right_left, tol.rematch_rot_deg,
                             tol.rematch_direction_deg, 1e9);
    if (!needed && !matches_off) continue;
    const bool rematch =
        matches_off || tol.rematch_rot_deg < 0 || kf->stereo_matched.disparity.empty();
    work[k] = rematch ? kRematch : kRetriangulate;
  }
  parallelFor(static_cast<int>(window.size()), resolveThreads(settings.threads), [&](int k) {
    if (work[k] == kRematch) recomputeStereo(window[k], rig, T_right_left, settings);
    if (work[k] == kRetriangulate) retriangulateStereo(window[k], rig, T_right_left, settings);
  });
  const int n =
      static_cast<int>(std::count_if(work.begin(), work.end(), [](Work w) { return w != kKeep; }));
  if (rematched) *rematched += static_cast<int>(std::count(work.begin(), work.end(), kRematch));
  // The LiDAR-stereo solver estimates one scale for the window: every cloud must share one
  // baseline length. A rectified cloud is linear in the baseline (Z = f b / d): rescale it.
  const double b = T_right_left.translation().norm();
  for (Keyframe* kf : window)
    if (std::fabs(kf->T_right_left_used.translation().norm() - b) > 1e-12 * b) rescaleStereo(kf, b);
  if (seconds) *seconds += secondsSince(t0);
  return n;
}

}  // namespace tescalib
