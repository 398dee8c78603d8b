// The wide-basin search of the LiDAR-stereo calibration (LidarStereoSettings::search_step_deg):
// solveLidarStereo from the initial guess and, when that does not converge, from the guess
// turned about the camera's x and y axes.
#include <cmath>
#include <optional>
#include <string>

#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {

LidarStereoResult solveLidarStereoSearch(const std::vector<const Keyframe*>& window,
                                         const Eigen::Isometry3d& T_init,
                                         const LidarStereoSettings& s) {
  LidarStereoResult first = solveLidarStereo(window, T_init, s);
  if (first.converged || !(s.search_step_deg > 0) || !std::isfinite(s.search_step_deg) ||
      window.empty() || !isRigidTransform(T_init))
    return first;
  const double step = s.search_step_deg / kDegPerRad;
  const double offsets[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  std::optional<LidarStereoResult> best;
  const int first_start = s.search_start >= 0 ? s.search_start % 8 : 0;
  const int starts = s.search_start >= 0 ? 1 : 8;
  for (int k = first_start; k < first_start + starts; ++k) {
    const auto& o = offsets[k];
    if (s.cancelled()) break;
    Vector6d d = Vector6d::Zero();
    d(0) = o[0] * step, d(1) = o[1] * step;
    LidarStereoResult r = solveLidarStereo(window, perturb(T_init, d), s);
    r.search_offset_rad = d.head<3>();
    if (r.converged && (!best || r.fine_inliers > best->fine_inliers)) best = std::move(r);
  }
  if (s.cancelled()) {
    first.message = "cancelled";
    return first;
  }
  if (best) {
    best->search_starts = 1 + starts;
    return *best;
  }
  first.search_starts = 1 + starts;
  const std::string which = starts == 1 ? "nor from the start " : "and from none of 8 starts ";
  first.message += " (" + which + "turned by +-" +
                   std::to_string(static_cast<int>(std::lround(s.search_step_deg))) +
                   " deg about the camera's x and y axes)";
  return first;
}

}  // namespace tescalib
