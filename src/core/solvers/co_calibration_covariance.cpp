#include "tescalib/core/solvers/co_calibration_covariance.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/uncertainty/fixed_point_covariance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

bool coStereoCovariance(const LidarStereoResult& lidar, const CoCalibrationSettings& s,
                        PhotometricResult* stereo) {
  return coStereoCovariance(lidar, s, stereo, lidar.covariance);
}

bool coStereoCovariance(const LidarStereoResult& lidar, const CoCalibrationSettings& s,
                        PhotometricResult* stereo, const Matrix6d& lidar_covariance,
                        const Matrix6d* lidar_sensitivity_to_stereo) {
  // The baseline length is the LiDAR-stereo solve's stereo scale times the length the clouds
  // were computed with (the photometric solves keep the length they are given): its variance
  // lies along the baseline, and only the rotation and the baseline direction come from the
  // photometric solve, so the length component of its LiDAR sensitivity is dropped.
  if (s.photometric_fixed_length) {
    const Eigen::Vector3d t = stereo->T_right_left.translation(), u = t.normalized();
    stereo->covariance.bottomRightCorner<3, 3>() += lidar.stereo_scale_variance * t * t.transpose();
    stereo->lidar_sensitivity.bottomRows<3>() -=
        u * (u.transpose() * stereo->lidar_sensitivity.bottomRows<3>());
  }
  // The left-right solve took the LiDAR extrinsic as exact: what its uncertainty does to the
  // key points' depth moves the left-right estimate (first order, PhotometricResult::
  // lidar_sensitivity), and with the LiDAR's sensitivity to the pair that loops back.
  if (lidar_sensitivity_to_stereo) {
    stereo->covariance = fixedPointCovariance(stereo->covariance, stereo->lidar_sensitivity,
                                              lidar_covariance, *lidar_sensitivity_to_stereo)
                             .covariance;
  } else {
    addLidarUncertainty(stereo, lidar_covariance);
  }
  // The photometric trust flags took the LiDAR extrinsic as exact too: judge them again with
  // what the length and the LiDAR add (the model error below stays out, as for the LiDAR flags).
  const bool all = trustFlags(stereo->covariance, s.stereo, stereo->observable);
  stereo->weak_directions =
      weakDirections(stereo->covariance, s.stereo.max_sigma_rot_deg, s.stereo.max_sigma_trans_m);
  if (!all && stereo->converged) {
    stereo->converged = false;
    stereo->message =
        "the window does not constrain every axis once the LiDAR extrinsic's uncertainty is "
        "included" +
        weakestClause(stereo->weak_directions);
  }
  addAxisVariances(&stereo->covariance, s.model_sigma_stereo_rot_deg, s.model_sigma_stereo_trans_m);
  return all;
}

void addScaleFloor(const LidarStereoSettings& lidar_settings, const CoCalibrationSettings& s,
                   LidarStereoResult* lidar) {
  if (!(s.model_sigma_stereo_scale > 0) || !lidar->covariance_known) return;
  const double sigma =
      s.model_sigma_stereo_scale * floorFocalBaselineFactor(*lidar, lidar_settings);
  const Vector6d& k = lidar->stereo_scale_sensitivity;
  lidar->stereo_scale_variance += sigma * sigma;
  lidar->covariance += sigma * sigma * k * k.transpose();
}

Matrix6d lidarSensitivityToStereo(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                  const LidarStereoResult& lidar, LidarStereoSettings settings,
                                  const CoCalibrationSettings& s, double* seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  Matrix6d J = Matrix6d::Zero();
  settings.run_coarse = false;
  settings.check_window_halves = false;
  settings.search_step_deg = 0;
  // Fine stage only: it stops at fine_settle_* (1e-3 deg / 0.3 mm; the converge_* tolerances are
  // the coarse stage's). A fine settle 0.3x as tight changes the columns by a few percent (the
  // translation response's nonlinearity dominates); 0.1x leaves a column
  // unsettled (zeroed).
  settings.initial_stereo_yaw_rad = lidar.stereo_yaw_rad;
  settings.initial_stereo_scale = lidar.stereo_scale;
  // What re-triangulating changes (and matching again, for a keyframe without matches), restored
  // at the end; the images of a StereoCloud are shared, not copied.
  struct Saved {
    StereoCloud stereo, matched;
    Eigen::Isometry3d used, matched_with;
  };
  std::vector<Saved> saved;
  for (const Keyframe* kf : window)
    saved.push_back(
        {kf->stereo, kf->stereo_matched, kf->T_right_left_used, kf->T_right_left_matched});
  const std::vector<const Keyframe*> cwin(window.begin(), window.end());
  const int threads = resolveThreads(s.stereo_cloud.threads);
  // Rotation about x and z, translation along y and z (perturb(): R = Exp(phi) R, t = t + tau).
  for (const int k : {0, 2, 4, 5}) {
    const double h = k < 3 ? s.sensitivity_step_rot_deg / kDegPerRad : s.sensitivity_step_trans_m;
    Vector6d moved[2];
    bool ok = true;
    for (int side = 0; side < 2 && ok; ++side) {
      Vector6d delta = Vector6d::Zero();
      delta[k] = side == 0 ? h : -h;
      parallelFor(static_cast<int>(window.size()), threads, [&](int i) {
        retriangulateStereo(window[i], rig, perturb(saved[i].used, delta), s.stereo_cloud);
      });
      const LidarStereoResult r = solveLidarStereo(cwin, lidar.T_cam_lidar, settings);
      ok = r.settled && !settings.cancelled();
      moved[side] = poseError(r.T_cam_lidar, lidar.T_cam_lidar);
    }
    // A solve that did not settle leaves the column at zero (no propagation from that axis).
    if (ok) J.col(k) = (moved[0] - moved[1]) / (2 * h);
  }
  for (size_t i = 0; i < window.size(); ++i) {
    Keyframe* kf = window[i];
    kf->stereo = std::move(saved[i].stereo), kf->stereo_matched = std::move(saved[i].matched);
    kf->T_right_left_used = saved[i].used, kf->T_right_left_matched = saved[i].matched_with;
  }
  if (seconds) *seconds = secondsSince(t0);
  return J;
}

void coCalibrationCovariances(const std::vector<Keyframe*>& window, const StereoRig& rig,
                              const LidarStereoSettings& lidar_settings,
                              const CoCalibrationSettings& s, CoCalibrationResult* res) {
  addScaleFloor(lidar_settings, s, &res->lidar);
  res->lidar_covariance_given_stereo = res->lidar.covariance;
  addAxisVariances(&res->lidar_covariance_given_stereo, s.model_sigma_lidar_rot_deg,
                   s.model_sigma_lidar_trans_m);
  // The left-right pair's uncertainty in the LiDAR covariance, through the LiDAR estimate's
  // sensitivity to the pair and the alternation's gain at its fixed point.
  // A warm update that cannot be stable takes an earlier full run's sensitivity.
  // Only a computed left-right covariance: a placeholder (identity) is not an uncertainty (it
  // would publish a 28.6 deg sigma with a converged LiDAR estimate).
  if (s.propagate_stereo_into_lidar && (res->stable || s.reuse_lidar_sensitivity) &&
      res->lidar.converged && res->stereo.covariance_known && res->stereo.covariance.allFinite()) {
    double seconds = 0;
    res->lidar_stereo_sensitivity =
        res->stable ? lidarSensitivityToStereo(window, rig, res->lidar, lidar_settings, s, &seconds)
                    : s.lidar_sensitivity_to_stereo;
    res->seconds_lidar += seconds;
    // Beyond a coupling of 0.9 the first-order gain is no longer to be trusted: the sensitivity
    // alone.
    const FixedPointCovariance p =
        fixedPointCovariance(res->lidar.covariance, res->lidar_stereo_sensitivity,
                             res->stereo.covariance, res->stereo.lidar_sensitivity, 0.9);
    res->coupling = p.coupling;
    res->lidar.covariance = p.covariance;
    if (std::getenv("TESCALIB_DEBUG"))
      std::fprintf(stderr,
                   "co: LiDAR sensitivity to the stereo pair (%.2f s), coupling %.3f, sigma added "
                   "rot [%.4f %.4f %.4f] deg trans [%.2f %.2f %.2f] mm\n",
                   seconds, res->coupling, std::sqrt(p.added(0, 0)) * kDegPerRad,
                   std::sqrt(p.added(1, 1)) * kDegPerRad, std::sqrt(p.added(2, 2)) * kDegPerRad,
                   std::sqrt(p.added(3, 3)) * 1e3, std::sqrt(p.added(4, 4)) * 1e3,
                   std::sqrt(p.added(5, 5)) * 1e3);
  }
  addAxisVariances(&res->lidar.covariance, s.model_sigma_lidar_rot_deg,
                   s.model_sigma_lidar_trans_m);
  // The pair's covariance takes the LiDAR's given the pair: the propagated one already holds the
  // pair's own uncertainty, which S would count a second time. The loop back through S enters as
  // the fixed point's gain (stereo_fixed_point_gain): the alternation couples by up to 0.7 on
  // generated windows, and the pair's error along the baseline's y and z follows the LiDAR's.
  // Only with a LiDAR covariance that was computed (a placeholder would swamp the pair's and call
  // a good left-right solve unconstrained, blaming it for the LiDAR's failure).
  const bool gain = s.stereo_fixed_point_gain && res->lidar_stereo_sensitivity.allFinite() &&
                    !res->lidar_stereo_sensitivity.isZero();
  if (res->lidar.covariance_known)
    coStereoCovariance(res->lidar, s, &res->stereo, res->lidar_covariance_given_stereo,
                       gain ? &res->lidar_stereo_sensitivity : nullptr);
}
}  // namespace tescalib
