#include "tescalib/core/online/pair_check.h"

#include <chrono>
#include <exception>

#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/co_calibration_covariance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

std::optional<PairCheck> checkStereoPair(
    const std::vector<std::shared_ptr<const Keyframe>>& keyframes, const StereoRig& rig,
    const OnlineEstimate& published, const OnlineSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<const Keyframe*> window;
  for (const auto& k : keyframes) window.push_back(k.get());
  if (window.empty()) return std::nullopt;
  // The cold solve's pyramid: a changed pair can be pixels away from the published one.
  const PhotometricSettings ps = coPhotometricSettings(settings.co, false);
  PhotometricResult r;
  try {
    r = solvePhotometric(window, rig, published.T_cam_lidar, published.T_right_left, ps);
  } catch (const std::exception&) {
    return std::nullopt;  // no check: the window's own solve is the evidence
  }
  if (!r.converged || !r.covariance_known) return std::nullopt;
  // The length is the published one, held: no variance of its own (the reference's covariance
  // holds the published length's).
  LidarStereoResult no_scale;
  no_scale.stereo_scale_variance = 0;
  coStereoCovariance(no_scale, settings.co, &r, published.cov_lidar_given_stereo);
  // A LiDAR change since the last check moves the depths, and through them the pair.
  Matrix6d lidar_change = Matrix6d::Zero();
  const MonitorSettings& m = settings.monitor;
  addAxisVariances(
      &lidar_change,
      {m.pair_check_lidar_change_deg, m.pair_check_lidar_change_deg, m.pair_check_lidar_change_deg},
      {m.pair_check_lidar_change_m, m.pair_check_lidar_change_m, m.pair_check_lidar_change_m});
  r.covariance += r.lidar_sensitivity * lidar_change * r.lidar_sensitivity.transpose();
  if (!r.covariance.allFinite()) return std::nullopt;
  PairCheck check;
  for (const auto& k : keyframes) check.stamps.push_back(k->stamp);
  check.T_right_left = r.T_right_left;
  check.covariance = r.covariance;
  check.seconds = secondsSince(t0);
  return check;
}

}  // namespace tescalib
