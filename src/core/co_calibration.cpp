#include "tescalib/core/co_calibration.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace tescalib {

namespace {
bool moved(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const CoCalibrationSettings& s) {
  const Vector6d d = poseError(a, b);
  return d.head<3>().norm() * kDegPerRad > s.stable_rot_deg ||
         d.tail<3>().norm() > s.stable_trans_m;
}
}  // namespace

CoCalibrationResult coCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const Eigen::Isometry3d& T_cam_lidar_init,
                                const Eigen::Isometry3d& T_right_left_init,
                                const CoCalibrationSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  CoCalibrationResult res;
  res.lidar.T_cam_lidar = T_cam_lidar_init;
  res.stereo.T_right_left = T_right_left_init;
  if (window.empty()) {
    res.message = "empty window";
    return res;
  }
  std::vector<const Keyframe*> cwin(window.begin(), window.end());
  Eigen::Isometry3d T_cl = T_cam_lidar_init, T_rl = T_right_left_init;
  for (res.rounds = 1; res.rounds <= s.max_rounds; ++res.rounds) {
    res.stereo = solvePhotometric(cwin, rig, T_cl, T_rl, s.stereo);
    Eigen::Isometry3d T_rl_new = res.stereo.T_right_left;
    const auto t_cloud = std::chrono::steady_clock::now();
    for (Keyframe* kf : window) recomputeStereo(kf, rig, T_rl_new, s.stereo_cloud);
    res.seconds_stereo_cloud +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_cloud).count();
    LidarStereoSettings ls = s.lidar;
    ls.disparity_sigma = s.stereo_cloud.disparity_sigma;
    // The LiDAR is metric; the photometric baseline is only as good as the LiDAR depth it used.
    // So the LiDAR-stereo solve also estimates the stereo cloud's scale, which corrects the
    // baseline length (rectification does not depend on it, the clouds simply scale).
    ls.estimate_stereo_scale = true;
    res.lidar = solveLidarStereo(cwin, T_cl, ls);
    T_rl_new.translation() *= res.lidar.stereo_scale;
    res.stereo.T_right_left = T_rl_new;
    const Eigen::Isometry3d T_cl_new = res.lidar.T_cam_lidar;
    const bool any_moved = moved(T_cl_new, T_cl, s) || moved(T_rl_new, T_rl, s);
    if (std::getenv("TESCALIB_DEBUG")) {
      const Eigen::Vector3d r = logSO3(T_rl_new.linear()) * kDegPerRad;
      std::fprintf(stderr,
                   "co round %d: scale %.4f T_rl rot [%.4f %.4f %.4f] deg t [%.4f %.4f %.4f]; "
                   "lidar %s %s; T_cl t [%.4f %.4f %.4f]\n",
                   res.rounds, res.lidar.stereo_scale, r.x(), r.y(), r.z(),
                   T_rl_new.translation().x(), T_rl_new.translation().y(),
                   T_rl_new.translation().z(), res.lidar.converged ? "conv" : "not conv",
                   res.lidar.message.c_str(), T_cl_new.translation().x(),
                   T_cl_new.translation().y(), T_cl_new.translation().z());
    }
    T_cl = T_cl_new, T_rl = T_rl_new;
    if (!any_moved && res.rounds > 1) {
      res.stable = true;
      break;
    }
  }
  res.rounds = std::min(res.rounds, s.max_rounds);
  res.converged = res.stable && res.lidar.converged && res.stereo.converged;
  if (!res.stable)
    res.message = "estimates still moving after " + std::to_string(s.max_rounds) + " rounds";
  else if (!res.stereo.converged)
    res.message = "left-right: " + res.stereo.message;
  else if (!res.lidar.converged)
    res.message = "LiDAR-stereo: " + res.lidar.message;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace tescalib
