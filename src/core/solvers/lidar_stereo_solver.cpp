// The LiDAR-stereo calibration over a window (paper, "LiDAR-stereo Calibration"): the coarse
// stage (lidar_stereo_coarse), the fine stage (lidar_stereo_fine), the covariance
// (lidar_stereo_covariance) and the verdict; the noise model of eq. lidar_noise and the
// disparity noise that weights the residuals of both stages.
#include "tescalib/core/solvers/lidar_stereo_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/lidar_stereo_coarse.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/solvers/lidar_stereo_fine.h"
#include "tescalib/core/solvers/lidar_stereo_update.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

using Clock = std::chrono::steady_clock;

/// Why the window, the initial guess or the settings cannot be solved; nullptr when they can.
const char* invalidInput(const std::vector<const Keyframe*>& window,
                         const Eigen::Isometry3d& T_init, const LidarStereoSettings& s) {
  if (window.empty()) return "empty window";
  if (!isRigidTransform(T_init))
    return "the initial T_cam_lidar is not a rigid transform (NaN, or not a rotation)";
  if (s.cov_cells_x < 1 || s.cov_cells_y < 1 || s.ceres_iterations < 1 || s.threads < 1)
    return "cov_cells_x, cov_cells_y, ceres_iterations and threads must be at least 1";
  if (s.ring_cluster_rings < 0) return "ring_cluster_rings must be 0 or more";
  if (s.fine_stereo_normal_px < 0) return "fine_stereo_normal_px must be 0 or more";
  // Non-finite or non-positive limits pass every gate (NaN compares false); bounds of zero width
  // make Ceres fail.
  for (const double v : {s.normal_weight, s.coarse_loss_scale, s.fine_huber, s.fine_gate_sigma,
                         s.max_depth, s.lidar_range_sigma, s.disparity_sigma})
    if (!(v > 0) || !std::isfinite(v))
      return "normal_weight, coarse_loss_scale, fine_huber, fine_gate_sigma, max_depth, "
             "lidar_range_sigma and disparity_sigma must be positive numbers";
  if ((s.estimate_stereo_scale &&
       (!(s.max_stereo_scale > 1) || !std::isfinite(s.max_stereo_scale) ||
        !(s.initial_stereo_scale > 0) || !std::isfinite(s.initial_stereo_scale))) ||
      (s.estimate_stereo_yaw &&
       (!(s.max_stereo_yaw_deg > 0) || !std::isfinite(s.max_stereo_yaw_deg) ||
        !std::isfinite(s.initial_stereo_yaw_rad))))
    return "the clouds' scale and yaw need max_stereo_scale > 1, max_stereo_yaw_deg > 0 and "
           "finite starts";
  return nullptr;
}

/// The roll about the optical axis (deg) by which the window's stereo clouds were rectified: the
/// angle of their left->right baseline off the left camera's x axis in the image plane (the
/// first keyframe's; 0 without keyframes or without a baseline along -x).
double rectificationRollDeg(const std::vector<const Keyframe*>& window) {
  if (window.empty() || !window.front()) return 0.0;
  const Eigen::Vector3d t = window.front()->T_right_left_used.translation();
  if (!(-t.x() > 0)) return 0.0;
  return std::atan2(t.y(), -t.x()) * kDegPerRad;
}

/// The start: T_init, and the clouds' scale and yaw from the settings (1 and 0 when held).
LidarStereoEstimate initialEstimate(const Eigen::Isometry3d& T_init, const LidarStereoSettings& s) {
  LidarStereoEstimate est;
  est.T = T_init;
  est.scale = s.estimate_stereo_scale
                  ? std::clamp(s.initial_stereo_scale, 1.0 / s.max_stereo_scale, s.max_stereo_scale)
                  : 1.0;
  est.yaw = s.estimate_stereo_yaw ? s.initial_stereo_yaw_rad : 0.0;
  return est;
}

/// Why a nuisance ended on its bound ("" when none did): a minimum on the bound is the bound's,
/// not the data's, and a pinned nuisance is not marginalised (its covariance not the pose's).
std::string nuisanceOnBound(const LidarStereoResult& res, const LidarStereoSettings& s) {
  char buf[200];
  if (s.estimate_stereo_scale &&
      std::fabs(std::log(res.stereo_scale)) >= std::log(s.max_stereo_scale) - 1e-4) {
    std::snprintf(buf, sizeof buf,
                  "the stereo scale ended on its bound (%.3f): the clouds' depth and the LiDAR's "
                  "disagree by more than a baseline error can explain",
                  res.stereo_scale);
    return buf;
  }
  if (s.estimate_stereo_yaw &&
      std::fabs(res.stereo_yaw_rad) * kDegPerRad >= s.max_stereo_yaw_deg - 1e-6) {
    std::snprintf(buf, sizeof buf,
                  "the clouds' yaw ended on its bound (%.3f deg): the right camera is turned "
                  "further than max_stereo_yaw_deg allows",
                  res.stereo_yaw_rad * kDegPerRad);
    return buf;
  }
  return "";
}

/// The stereo pair's f x B error the estimated clouds' scale shows, as a clause ("" unless the
/// scale is estimated and off 1 by more than 2 sigma and 0.3 %).
std::string scaleClause(const LidarStereoResult& res, const LidarStereoSettings& s) {
  const double off = res.stereo_scale - 1, sigma = std::sqrt(res.stereo_scale_variance);
  if (!s.estimate_stereo_scale || !(std::fabs(off) > std::max(2 * sigma, 0.003))) return "";
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "; the stereo pair's f x B looks %+.1f %% (+- %.1f %%) off its calibration's",
                100 * off, 100 * sigma);
  return buf;
}

/// Why the window does not constrain every axis, with the error sources it suspects: the
/// rectification or matching (a common disparity offset beyond the model's), the pair's f x B
/// (the clouds' scale), else the scene.
std::string unconstrainedMessage(const LidarStereoResult& res, const LidarStereoSettings& s) {
  const std::string scale = scaleClause(res, s);
  if (!disparityOffsetWidensBias(res, s))
    return "the window does not constrain every axis (" +
           std::string(scale.empty() ? "degenerate scene)" : "suspected sensor error)") + scale +
           weakestClause(res.weak_directions);
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "the window does not constrain every axis with the common disparity offset its "
                "residuals show (%+.2f px, model %.2f px: rectification or matching bias?)",
                res.disparity_offset_px, s.model_sigma_disparity_px);
  return buf + scale + weakestClause(res.weak_directions);
}

/// An unsettled fine stage's drift (LidarStereoEstimate::fine_drift) in units of the trust limits:
/// where it moved by more than a limit the window does not hold the estimate, so those axes are not
/// trusted and the drift leads the weak directions (a covariance taken at an estimate that is
/// still moving can look tight along the very direction it moves in).
/// Returns whether it flagged anything.
bool flagDrift(const Vector6d& drift, const LidarStereoSettings& s, LidarStereoResult* res) {
  const Vector6d u = drift.cwiseProduct(limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m));
  const WeakDirection w = weakDirectionAlong(u);
  if (!(w.ratio > 1.0)) return false;
  for (int i = 0; i < 6; ++i)
    if (std::fabs(u[i]) > 1.0) res->observable[i] = false;
  res->weak_directions.insert(res->weak_directions.begin(), w);
  return true;
}

/// Sets `res.converged`, or the message saying why it is not.
void judgeConvergence(const Eigen::Isometry3d& T_init, const LidarStereoSettings& s,
                      bool all_observable, bool settled, bool drifting, LidarStereoResult* res) {
  const Vector6d correction = poseError(res->T_cam_lidar, T_init);
  const bool diverged = correction.head<3>().norm() * kDegPerRad > s.max_correction_rot_deg ||
                        correction.tail<3>().norm() > s.max_correction_trans_m;
  res->converged = res->only_unconstrained = false;
  if (res->fine_inliers < s.min_inliers && s.run_fine)
    res->message = "too few LiDAR-stereo associations (" + std::to_string(res->fine_inliers) + ")";
  else if (diverged)
    res->message = "diverged: the correction from the initial guess is implausibly large";
  else if (const std::string bound = nuisanceOnBound(*res, s); !bound.empty())
    res->message = bound;
  else if (drifting)
    res->message = "the fine stage keeps moving: the window does not hold the estimate" +
                   scaleClause(*res, s) + weakestClause(res->weak_directions);
  else if (res->fixed_point_contraction >= 1.0)
    res->message =
        "the fine stage's re-association does not contract: the window does not hold its fixed "
        "point" +
        weakestClause(res->weak_directions);
  else if (!all_observable) {
    res->message = unconstrainedMessage(*res, s);
    res->only_unconstrained = settled;
  } else if (!settled)
    res->message = "the fine stage did not settle within its iteration budget";
  else
    res->converged = true;
}

}  // namespace

bool disparityOffsetMeasured(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return r.disparity_offset_sigma_px > 0 &&
         r.disparity_offset_sigma_px <= s.max_disparity_offset_sigma_px &&
         std::fabs(r.disparity_offset_px) >
             s.disparity_offset_significance * r.disparity_offset_sigma_px;
}

double disparityBiasSigma(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return disparityOffsetMeasured(r, s)
             ? std::max(s.model_sigma_disparity_px, std::fabs(r.disparity_offset_px))
             : s.model_sigma_disparity_px;
}

bool disparityOffsetWidensBias(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return disparityBiasSigma(r, s) > s.model_sigma_disparity_px;
}

bool trustFlags(const Matrix6d& covariance, const LidarStereoSettings& s, bool observable[6]) {
  return axesWithin(covariance, s.max_sigma_rot_deg, s.max_sigma_trans_m, observable);
}

// Variance of a LiDAR point along unit normal n (camera frame), eq. lidar_noise projected:
// range noise along the beam, beam-direction noise (times the range) across it.
double lidarVarianceAlong(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const LidarStereoSettings& s) {
  const double c = n.dot(beam_dir);
  const double lateral = range * s.lidar_beam_sigma_deg * M_PI / 180.0;
  return s.lidar_range_sigma * s.lidar_range_sigma * c * c + lateral * lateral * (1.0 - c * c);
}

double pointPlaneInvSigma(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const Eigen::Vector3d& stereo_point, double disparity,
                          double stereo_scale, double disparity_sigma,
                          const LidarStereoSettings& s) {
  const double dFdd = stereo_scale * std::fabs(n.dot(stereo_point)) / disparity;
  const double var =
      lidarVarianceAlong(n, beam_dir, range, s) + dFdd * dFdd * disparity_sigma * disparity_sigma;
  return 1.0 / std::sqrt(var);
}

LidarStereoResult solveLidarStereo(const std::vector<const Keyframe*>& window,
                                   const Eigen::Isometry3d& T_init, const LidarStereoSettings& s) {
  LidarStereoResult res;
  res.T_cam_lidar = T_init;
  res.T_after_coarse = T_init;
  if (const char* invalid = invalidInput(window, T_init, s)) {
    res.message = invalid;
    return res;
  }
  LidarStereoEstimate est = initialEstimate(T_init, s);
  const auto t_coarse = Clock::now();
  if (s.run_coarse && !runCoarseStage(window, s, &est, &res)) return res;  // cancelled
  res.T_after_coarse = est.T;
  res.seconds_coarse = secondsSince(t_coarse);
  const auto t_fine = Clock::now();
  est.settled = !s.run_fine;
  if (s.run_fine && !est.solver_failed && !runFineStage(window, s, &est, &res)) return res;
  res.seconds_fine = secondsSince(t_fine);
  res.T_cam_lidar = est.T;
  res.stereo_scale = est.scale;
  res.stereo_yaw_rad = est.yaw;
  res.ring_range_offsets_m = est.ring_offsets;
  res.settled = est.settled && !est.solver_failed;
  if (est.solver_failed) {
    res.message = "Ceres could not solve an update (NaN residuals, or an infeasible bound)";
    return res;
  }
  res.rectification_roll_deg = rectificationRollDeg(window);
  if (!window.empty() && window.front()) {
    res.focal_baseline_px_m = window.front()->stereo.fx * window.front()->stereo.baseline;
    res.vertical_low_pass_px = window.front()->stereo.vertical_low_pass_px;
  }
  const bool covariance_holds = estimateLidarStereoCovariance(est, s, window.size(), &res);
  // A drift the covariance does not show is named as such; one it shows adds to its message.
  const bool drifting = !est.settled && flagDrift(est.fine_drift, s, &res);
  const bool all_observable =
      std::all_of(res.observable, res.observable + 6, [](bool b) { return b; });
  judgeConvergence(T_init, s, all_observable, est.settled, drifting && covariance_holds, &res);
  if (windowHalvesDue(res, s)) checkWindowHalves(window, s, T_init, &res);
  // Cancelled at any point (a stage, or the halves): not converged, whatever it reached (the
  // header's promise; a cancel during the halves would otherwise leave a "tested" check).
  if (s.cancelled()) {
    res.converged = false;
    res.message = "cancelled";
  }
  return res;
}

}  // namespace tescalib
