#include "tescalib/core/solvers/co_calibration.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/co_alternation.h"

namespace tescalib {

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

RectifyTolerances rectifyTolerances(const CoCalibrationSettings& s) {
  RectifyTolerances t;
  t.rot_deg = s.rerectify_deg;
  t.direction_deg = s.rerectify_direction_deg;
  t.yaw_deg = s.lidar_estimates_stereo_yaw ? s.rerectify_yaw_deg : -1.0;
  t.rematch_rot_deg = s.rematch_deg;
  t.rematch_direction_deg = s.rematch_direction_deg;
  return t;
}

LidarStereoSettings coLidarStereoSettings(const CoCalibrationSettings& s) {
  LidarStereoSettings ls = s.lidar;
  ls.disparity_sigma = s.stereo_cloud.disparity_sigma;
  ls.estimate_stereo_scale = true;
  // The clouds' rectification yaw is a nuisance here: a yaw error of the right camera shifts
  // every disparity, which the LiDAR would otherwise absorb along the optical axis; the yaw
  // itself stays the photometric solver's (with a good LiDAR it is far more precise).
  ls.estimate_stereo_yaw = s.lidar_estimates_stereo_yaw;
  ls.fine_reassociations = std::min(ls.fine_reassociations, s.round_fine_reassociations);
  ls.fine_stereo_normal_px = s.fine_stereo_normal_px;
  return ls;
}

PhotometricSettings coPhotometricSettings(const CoCalibrationSettings& s, bool warm) {
  PhotometricSettings ps = s.stereo;
  ps.fix_baseline_length = s.photometric_fixed_length;
  if (warm) {
    ps.pyramid_levels = std::min(ps.pyramid_levels, s.warm_pyramid_levels);
    ps.iterations_per_level = s.warm_iterations;
  }
  return ps;
}

std::string secondOpinion(const std::vector<const Keyframe*>& window,
                          const Eigen::Isometry3d& T_cam_lidar_init, const LidarStereoResult& lidar,
                          const LidarStereoSettings& settings, const CoCalibrationSettings& s,
                          double* seconds) {
  if (seconds) *seconds = 0;
  if (!lidar.converged || (s.confirm_beyond_deg < 0 && s.confirm_beyond_m < 0)) return "";
  const Vector6d moved = poseError(lidar.T_cam_lidar, T_cam_lidar_init);
  const double moved_deg = moved.head<3>().norm() * kDegPerRad, moved_m = moved.tail<3>().norm();
  if (!((s.confirm_beyond_deg >= 0 && moved_deg >= s.confirm_beyond_deg) ||
        (s.confirm_beyond_m >= 0 && moved_m >= s.confirm_beyond_m)))
    return "";
  const auto t0 = Clock::now();
  LidarStereoSettings ls = settings;
  ls.run_coarse = true;
  ls.initial_stereo_scale = lidar.stereo_scale;  // the final clouds' scale and yaw, as found
  ls.initial_stereo_yaw_rad = lidar.stereo_yaw_rad;
  const LidarStereoResult again = solveLidarStereo(window, T_cam_lidar_init, ls);
  if (seconds) *seconds = secondsSince(t0);
  if (!again.converged) return ls.cancelled() ? "cancelled during the second opinion" : "";
  const Vector6d gap = poseError(again.T_cam_lidar, lidar.T_cam_lidar);
  const double gap_deg = gap.head<3>().norm() * kDegPerRad, gap_m = gap.tail<3>().norm();
  if (gap_deg <= s.confirm_disagree_deg && gap_m <= s.confirm_disagree_m) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "two minima: the estimate moved %.2f deg / %.2f m from the initial guess, and a "
                "solve from the initial guess with the final clouds converged %.2f deg / %.2f m "
                "away from it",
                moved_deg, moved_m, gap_deg, gap_m);
  return buf;
}

namespace {

// The final LiDAR estimate's checks, on the clouds the last solve used: the split-window check of
// the LiDAR-stereo noise model (also after an unstable run, for the online node's warm rounds,
// which take a converged LiDAR-stereo solve as it is), and a second opinion from the initial guess
// on a stable estimate far from it.
void checkFinalLidar(const CoAlternation& a, CoCalibrationResult* res) {
  // Due by the caller's settings: the inner solves' (ls_last) switch the check off.
  if (windowHalvesDue(res->lidar, a.s.lidar)) {
    const auto t_h = Clock::now();
    LidarStereoSettings hs = a.ls_last;
    if (a.s.halves_always_from_initial_guess &&
        hs.halves_start == HalvesStart::kEstimateThenInitialGuess)
      hs.halves_start = HalvesStart::kEstimateAndInitialGuess;
    checkWindowHalves(a.cwin, hs, a.T_cam_lidar_init, &res->lidar);
    res->seconds_lidar += secondsSince(t_h);
  }
  if (res->stable && res->lidar.converged) {
    double seconds = 0;
    const std::string doubt =
        secondOpinion(a.cwin, a.T_cam_lidar_init, res->lidar, a.ls_last, a.s, &seconds);
    res->seconds_lidar += seconds;
    if (a.debug && seconds > 0)
      std::fprintf(stderr, "co second opinion (%.2f s): %s\n", seconds,
                   doubt.empty() ? "agrees or did not converge" : doubt.c_str());
    if (!doubt.empty()) res->lidar.converged = false, res->lidar.message = doubt;
  }
}

// Whether the alternation converged, and why not.
void finalVerdict(const CoAlternation& a, CoCalibrationResult* res) {
  const CoCalibrationSettings& s = a.s;
  res->converged = res->stable && res->lidar.converged && res->stereo.converged;
  if (!a.unrectifiable.empty())
    res->converged = false, res->message = a.unrectifiable;
  else if (a.stuck)
    res->message = "LiDAR-stereo ran away from the initial guess in " +
                   std::to_string(res->rejected) +
                   " rounds, the last two started from the same estimates and clouds (a start "
                   "beyond the basin?)";
  else if (!res->stable)
    res->message = "estimates still moving after " + std::to_string(s.max_rounds) + " rounds" +
                   (res->rejected ? " (" + std::to_string(res->rejected) +
                                        " LiDAR-stereo estimates ran away from the initial guess "
                                        "and were not taken)"
                                  : "");
  else if (!res->stereo.converged)
    res->message = "left-right: " + res->stereo.message;
  else if (!res->lidar.converged)
    res->message = "LiDAR-stereo: " + res->lidar.message;
  // Cancelled after the rounds: the split-window check, the second opinion or the sensitivity to
  // the pair may have been cut short (jointCalibrate does the same).
  if (s.lidar.cancelled()) res->converged = false, res->message = "cancelled";
}

}  // namespace

CoCalibrationResult coCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const Eigen::Isometry3d& T_cam_lidar_init,
                                const Eigen::Isometry3d& T_right_left_init,
                                const CoCalibrationSettings& s) {
  const auto t0 = Clock::now();
  CoCalibrationResult res;
  res.lidar.T_cam_lidar = T_cam_lidar_init;
  res.stereo.T_right_left = T_right_left_init;
  const std::string pair_problem = stereoExtrinsicProblem(T_right_left_init);
  if (!pair_problem.empty() || !isRigidTransform(T_cam_lidar_init)) {
    res.message = !pair_problem.empty()
                      ? "initial guess: " + pair_problem
                      : "the initial T_cam_lidar is not a rigid transform (NaN, or not a rotation)";
    return res;
  }
  if (window.empty()) {
    res.message = "empty window";
    return res;
  }
  CoAlternation a(window, rig, T_cam_lidar_init, T_right_left_init, s, &res);
  const CoPhase end = a.run();
  if (end != CoPhase::kCancelled) res.rounds = std::min(res.rounds, s.max_rounds);
  // Cancelled before a round, or within the last one (its solves returned their starts).
  if (end == CoPhase::kCancelled || s.lidar.cancelled()) {
    res.converged = false;
    res.message = "cancelled";
    return res;
  }
  checkFinalLidar(a, &res);
  coCalibrationCovariances(window, rig, a.ls_last, s, &res);
  finalVerdict(a, &res);
  res.seconds = secondsSince(t0);
  return res;
}

}  // namespace tescalib
