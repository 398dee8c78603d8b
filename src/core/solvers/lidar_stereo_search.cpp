// The wide-basin search of the LiDAR-stereo calibration (LidarStereoSettings::search_step_deg):
// solveLidarStereo from the initial guess and, when that does not converge, from the guess
// turned about the camera's x and y axes.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tescalib/core/solvers/lidar_stereo_judge.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {
namespace {

void printStart(const char* which, const LidarStereoResult& r) {
  const Eigen::Vector3d t = r.T_cam_lidar.translation();
  std::fprintf(stderr,
               "search %s: converged %d, settled %d, fine inliers %d, cost %.4f, t [%.3f %.3f "
               "%.3f] m: %s\n",
               which, r.converged, r.settled, r.fine_inliers, r.final_cost, t.x(), t.y(), t.z(),
               r.message.c_str());
}

}  // namespace

LidarStereoResult solveLidarStereoSearch(const std::vector<const Keyframe*>& window,
                                         const Eigen::Isometry3d& T_init,
                                         const LidarStereoSettings& s) {
  const bool debug = std::getenv("TESCALIB_DEBUG") != nullptr;
  std::vector<LidarStereoResult> tried;
  tried.reserve(9);
  tried.push_back(solveLidarStereo(window, T_init, s));
  if (debug) printStart("from the initial guess", tried[0]);
  if (tried[0].converged || !(s.search_step_deg > 0) || !std::isfinite(s.search_step_deg) ||
      window.empty() || !isRigidTransform(T_init))
    return tried[0];
  const double step = s.search_step_deg / kDegPerRad;
  const double offsets[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  const int first_start = s.search_start >= 0 ? s.search_start % 8 : 0;
  const int starts = s.search_start >= 0 ? 1 : 8;
  for (int k = first_start; k < first_start + starts; ++k) {
    const auto& o = offsets[k];
    if (s.cancelled()) break;
    Vector6d d = Vector6d::Zero();
    d(0) = o[0] * step, d(1) = o[1] * step;
    tried.push_back(solveLidarStereo(window, perturb(T_init, d), s));
    tried.back().search_offset_rad = d.head<3>();
    if (debug) printStart(("start " + std::to_string(k)).c_str(), tried.back());
  }
  LidarStereoResult first = tried[0];
  if (s.cancelled()) {
    first.message = "cancelled";
    return first;
  }
  const LidarStereoResult* best = nullptr;
  for (const LidarStereoResult& r : tried)
    if (r.converged && (!best || r.fine_inliers > best->fine_inliers)) best = &r;
  if (best) {
    LidarStereoResult chosen = *best;
    refuseBesideRivalMinimum(tried, s, &chosen);
    chosen.search_starts = 1 + starts;
    return chosen;
  }
  first.search_starts = 1 + starts;
  const std::string which = starts == 1 ? "nor from the start " : "and from none of 8 starts ";
  first.message += " (" + which + "turned by +-" +
                   std::to_string(static_cast<int>(std::lround(s.search_step_deg))) +
                   " deg about the camera's x and y axes)";
  return first;
}

}  // namespace tescalib
