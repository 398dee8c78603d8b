#include "tescalib/core/online/window_solve.h"

#include <algorithm>

#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/joint_calibration.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {
namespace {

/// Whether a solve without an estimate may try the wide-basin search: before the first estimate,
/// once the window holds min(window_size, search_min_keyframes) keyframes.
bool searchAllowed(const WindowSolveInput& in, const OnlineSettings& s) {
  return !in.published &&
         static_cast<int>(in.keyframes.size()) >= std::min(s.window_size, s.search_min_keyframes);
}

/// The co-calibration's settings for `in`; `warm`: an update of a co-calibrated estimate by warm
/// rounds (OnlineSettings::warm_co_rounds).
CoCalibrationSettings coSettings(const WindowSolveInput& in, const OnlineSettings& s,
                                 const std::atomic<bool>* cancel, bool* warm) {
  const std::optional<OnlineEstimate>& current = in.published;
  CoCalibrationSettings cs = s.co;
  cs.lidar.cancel = cancel;
  cs.lidar.halves_when_unsettled = current.has_value();  // the monitor's evidence (newerHalf)
  // Its LiDAR-first fallback searches as the LiDAR-stereo solves do.
  if (!searchAllowed(in, s)) cs.lidar.search_step_deg = 0;
  if (s.spread_search) cs.lidar.search_start = in.search_start;
  // The pair from feature matches only for a start without an estimate: from a LiDAR-first one
  // round 1's photometric solve has good depth, and its yaw is far tighter than the matches'
  // (generated windows: 0.03-0.07 deg off; real KITTI 0.13-0.15 deg).
  if (current) cs.stereo_from_features = false;
  // Warm only from a co-calibration: a LiDAR-first estimate has the stereo pair at its start.
  const bool from_co = current && current->stereo_estimated && s.warm_start_fine_only &&
                       in.last_converged && !in.recalibrating;
  // The joint solve has no warm rounds: it starts from the estimate (see OnlineSettings), and
  // its initial round's LiDAR-stereo solve runs the fine stage alone, as a warm LiDAR-stereo
  // update does.
  if (s.joint && from_co) cs.lidar.run_coarse = false;
  *warm = from_co && !s.joint;
  if (*warm) {
    cs.warm_first_round = true;
    cs.max_rounds = std::min(cs.max_rounds, s.warm_co_rounds);
    // Its LiDAR covariance must hold the pair's uncertainty as the published one does.
    if (in.lidar_sensitivity) {
      cs.reuse_lidar_sensitivity = true;
      cs.lidar_sensitivity_to_stereo = *in.lidar_sensitivity;
    }
  }
  return cs;
}

/// The estimate of a co-calibration. A warm update counts as converged when both of its solves
/// converged (it has no stability criterion of its own).
OnlineEstimate coEstimate(const CoCalibrationResult& r, bool warm) {
  OnlineEstimate e;
  e.T_cam_lidar = r.lidar.T_cam_lidar;
  e.T_right_left = r.stereo.T_right_left;
  e.cov_lidar = r.lidar.covariance;
  e.cov_lidar_known = r.lidar.covariance_known;
  e.cov_stereo_known = r.stereo.covariance_known;
  e.cov_lidar_given_stereo = r.lidar_covariance_given_stereo;
  e.cov_stereo = r.stereo.covariance;
  std::copy(r.lidar.observable, r.lidar.observable + 6, e.observable_lidar);
  e.weakest_lidar = r.lidar.weakest();
  e.weakest_stereo = r.stereo.weakest();
  std::copy(r.stereo.observable, r.stereo.observable + 6, e.observable_stereo);
  e.converged = warm ? r.lidar.converged && r.stereo.converged : r.converged;
  e.cost_lidar = r.lidar.final_cost, e.cost_stereo = r.stereo.final_cost;
  e.iterations_lidar = r.lidar.iterations, e.iterations_stereo = r.stereo.iterations;
  e.co_rounds = r.rounds;
  e.stereo_estimated = true;
  return e;
}

/// Whether `r`'s window was split in halves and they disagreed (LidarStereoResult::Halves).
bool halvesDisagree(const LidarStereoResult& r, const LidarStereoSettings& settings) {
  return r.halves.tested && r.halves.chi2 > settings.halves_chi2_limit;
}

WindowSolveResult coCalibrateWindow(const WindowSolveInput& in, const StereoRig& rig,
                                    const OnlineSettings& s, const std::atomic<bool>* cancel) {
  bool warm = false;
  const CoCalibrationSettings cs = coSettings(in, s, cancel, &warm);
  std::vector<Keyframe*> win;
  for (const auto& k : in.keyframes) win.push_back(k.get());
  CoCalibrationResult r;
  if (s.joint) {
    JointCalibrationSettings js;
    js.co = cs;
    r = jointCalibrate(win, rig, in.T_cam_lidar, in.T_right_left, js);
  } else {
    r = coCalibrate(win, rig, in.T_cam_lidar, in.T_right_left, cs);
  }
  WindowSolveResult out;
  out.solver_cancelled = r.message == "cancelled";
  if (!warm && r.stable && !r.lidar_stereo_sensitivity.isZero())
    out.lidar_sensitivity = r.lidar_stereo_sensitivity;
  out.clouds_recomputed = true;
  out.searched = r.lidar.search_starts > 1;
  out.newer_half = newerHalf(r.lidar, cs.lidar, in.keyframes);
  out.keyframe_information = r.lidar.keyframe_information;
  out.estimate = coEstimate(r, warm);
  out.stereo_settled = r.stereo.converged && r.stereo.covariance_known;
  out.co_halves_disagree = halvesDisagree(r.lidar, cs.lidar);
  if (!warm)
    out.message = r.message;
  else if (!r.stereo.converged)
    out.message = "left-right: " + r.stereo.message;
  else if (!r.lidar.converged)
    out.message = "LiDAR-stereo: " + r.lidar.message;
  return out;
}

/// LiDAR-stereo alone: T_right_left stays the published (or initial) one, and a co-calibrated
/// pair keeps its uncertainty.
WindowSolveResult solveLidarStereoWindow(const WindowSolveInput& in, const OnlineSettings& s,
                                         const std::atomic<bool>* cancel) {
  const std::optional<OnlineEstimate>& current = in.published;
  std::vector<const Keyframe*> cwin;
  for (const auto& k : in.keyframes) cwin.push_back(k.get());
  LidarStereoSettings ls = s.co.lidar;
  ls.cancel = cancel;
  ls.disparity_sigma = s.keyframe.stereo.disparity_sigma;
  if (current && s.warm_start_fine_only && in.last_converged) ls.run_coarse = false;
  ls.halves_when_unsettled = current.has_value();  // the monitor's evidence (newerHalf)
  if (!searchAllowed(in, s)) ls.search_step_deg = 0;
  if (s.spread_search) ls.search_start = in.search_start;
  const LidarStereoResult r = solveLidarStereoSearch(cwin, in.T_cam_lidar, ls);
  WindowSolveResult out;
  out.searched = r.search_starts > 1;
  out.newer_half = newerHalf(r, ls, in.keyframes);
  out.settled_unconstrained = r.only_unconstrained && r.covariance_known && !halvesDisagree(r, ls);
  if (out.settled_unconstrained)
    out.unconstrained_lidar =
        beyondLimits(r.weak_directions, ls.max_sigma_rot_deg, ls.max_sigma_trans_m);
  out.solver_cancelled = r.message == "cancelled";
  out.keyframe_information = r.keyframe_information;
  OnlineEstimate& e = out.estimate;
  e.T_cam_lidar = r.T_cam_lidar;
  e.T_right_left = in.T_right_left;
  e.cov_lidar = e.cov_lidar_given_stereo = r.covariance;
  e.cov_lidar_known = r.covariance_known;
  e.cov_stereo = Matrix6d::Zero();
  std::copy(r.observable, r.observable + 6, e.observable_lidar);
  e.weakest_lidar = r.weakest();
  std::fill(e.observable_stereo, e.observable_stereo + 6, true);
  if (current && current->stereo_estimated) {  // keep a co-calibrated stereo pair as it is
    e.cov_stereo = current->cov_stereo;
    e.cov_stereo_known = current->cov_stereo_known;
    std::copy(current->observable_stereo, current->observable_stereo + 6, e.observable_stereo);
    e.weakest_stereo = current->weakest_stereo;
    e.stereo_estimated = true;
  }
  e.converged = r.converged;
  e.cost_lidar = r.final_cost;
  e.iterations_lidar = r.iterations;
  out.message = r.message;
  return out;
}

}  // namespace

bool coCalibrationDue(const OnlineSettings& settings, int fill, bool estimate_published,
                      bool recording_ended) {
  return settings.estimate_stereo &&
         (!settings.lidar_first ||
          (fill >= settings.min_keyframes_co &&
           (estimate_published || fill >= settings.window_size || recording_ended)));
}

std::optional<NewerHalfEstimate> newerHalf(
    const LidarStereoResult& r, const LidarStereoSettings& settings,
    const std::vector<std::shared_ptr<Keyframe>>& keyframes) {
  const LidarStereoResult::Halves& h = r.halves;
  if (!halvesDisagree(r, settings) || !h.second_settled || h.second_begin >= keyframes.size())
    return std::nullopt;
  NewerHalfEstimate half;
  for (size_t i = h.second_begin; i < keyframes.size(); ++i)
    half.stamps.push_back(keyframes[i]->stamp);
  half.T_cam_lidar = h.second_T;
  half.covariance = h.second_covariance;
  half.unconstrained = beyondLimits(h.second_weak_directions, settings.max_sigma_rot_deg,
                                    settings.max_sigma_trans_m);
  return half;
}

WindowSolveResult solveWindow(const WindowSolveInput& input, const StereoRig& rig,
                              const OnlineSettings& settings, const std::atomic<bool>* cancel) {
  return input.co ? coCalibrateWindow(input, rig, settings, cancel)
                  : solveLidarStereoWindow(input, settings, cancel);
}

}  // namespace tescalib
