#include "eval_trial.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/eval/gicp_baseline.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/joint_calibration.h"
#include "tescalib/core/solvers/photometric_solver.h"
#include "tescalib/core/solvers/stereo_features.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib::eval {

using Clock = std::chrono::steady_clock;

LidarStereoSettings lidarSettings(const Args& args, const KeyframeSettings& kfs) {
  LidarStereoSettings solver_settings;
  solver_settings.disparity_sigma = kfs.stereo.disparity_sigma;
  solver_settings.run_coarse = args.stages.find("coarse") != std::string::npos;
  solver_settings.run_fine = args.stages.find("fine") != std::string::npos;
  if (args.cov_cells_x > 0) solver_settings.cov_cells_x = args.cov_cells_x;
  if (args.stereo_yaw >= 0) solver_settings.estimate_stereo_yaw = args.stereo_yaw > 0;
  if (args.stereo_scale >= 0) solver_settings.estimate_stereo_scale = args.stereo_scale > 0;
  if (args.check_halves >= 0) solver_settings.check_window_halves = args.check_halves > 0;
  if (args.halves_start >= 0) solver_settings.halves_start = HalvesStart(args.halves_start);
  if (args.measure_offset >= 0) solver_settings.measure_disparity_offset = args.measure_offset > 0;
  if (args.coarse_nuisances >= 0)
    solver_settings.coarse_estimates_stereo_nuisances = args.coarse_nuisances > 0;
  if (!args.coarse_gates.empty()) solver_settings.coarse_gates = args.coarse_gates;
  if (args.search_deg >= 0) solver_settings.search_step_deg = args.search_deg;
  if (args.cov_cells_y > 0) solver_settings.cov_cells_y = args.cov_cells_y;
  if (args.ring_clusters >= 0) solver_settings.ring_cluster_rings = args.ring_clusters;
  if (args.ring_range_sigma >= 0) solver_settings.ring_range_sigma_m = args.ring_range_sigma;
  if (args.fine_gain_probe >= 0) solver_settings.fine_gain_probe = args.fine_gain_probe;
  if (args.fine_settle_walk >= 0) solver_settings.fine_settle_walk = args.fine_settle_walk;
  if (args.fine_stereo_normal_px >= 0)
    solver_settings.fine_stereo_normal_px = args.fine_stereo_normal_px;
  if (args.cov_model_scale >= 0) {
    for (double& v : solver_settings.model_sigma_rot_deg) v *= args.cov_model_scale;
    for (double& v : solver_settings.model_sigma_trans_m) v *= args.cov_model_scale;
    solver_settings.model_sigma_disparity_px *= args.cov_model_scale;
    solver_settings.model_sigma_range_m *= args.cov_model_scale;
  }
  return solver_settings;
}

namespace {

/// Co-calibration's settings: its defaults, the LiDAR-stereo study options and its own.
CoCalibrationSettings coSettings(const Args& args, const LidarStereoSettings& solver_settings,
                                 const DisparityRefinementSettings& refinement) {
  CoCalibrationSettings cs;
  cs.stereo_cloud.refinement = refinement;
  cs.stereo_cloud.sgbm_paths = args.sgbm_paths;
  cs.stereo_cloud.sgbm_both_ways = args.sgbm_both_ways;
  cs.lidar.cov_cells_x = solver_settings.cov_cells_x;
  cs.lidar.cov_cells_y = solver_settings.cov_cells_y;
  cs.lidar.ring_cluster_rings = solver_settings.ring_cluster_rings;
  cs.lidar.ring_range_sigma_m = solver_settings.ring_range_sigma_m;
  cs.lidar.model_sigma_rot_deg = solver_settings.model_sigma_rot_deg;
  cs.lidar.model_sigma_trans_m = solver_settings.model_sigma_trans_m;
  cs.lidar.model_sigma_disparity_px = solver_settings.model_sigma_disparity_px;
  cs.lidar.model_sigma_range_m = solver_settings.model_sigma_range_m;
  cs.lidar.check_window_halves = solver_settings.check_window_halves;
  cs.lidar.halves_start = solver_settings.halves_start;
  cs.lidar.coarse_estimates_stereo_nuisances = solver_settings.coarse_estimates_stereo_nuisances;
  cs.lidar.measure_disparity_offset = solver_settings.measure_disparity_offset;
  cs.lidar.fine_gain_probe = solver_settings.fine_gain_probe;
  cs.lidar.fine_settle_walk = solver_settings.fine_settle_walk;
  if (args.smooth_keypoints_px >= 0) cs.stereo.smooth_depth_radius_px = args.smooth_keypoints_px;
  if (args.depth_prior >= 0) cs.free_depth_prior_sigma = args.depth_prior;
  if (args.free_depth_rounds >= 0) cs.free_depth_rounds = args.free_depth_rounds;
  if (args.lidar_first >= 0) cs.lidar_first_fallback = args.lidar_first > 0;
  if (args.features >= 0) cs.stereo_from_features = args.features > 0;
  if (args.co_halves >= 0) cs.halves_always_from_initial_guess = args.co_halves > 0;
  if (args.fine_stereo_normal_px >= 0) cs.fine_stereo_normal_px = args.fine_stereo_normal_px;
  if (args.propagate_stereo >= 0) cs.propagate_stereo_into_lidar = args.propagate_stereo > 0;
  cs.lidar.search_step_deg = solver_settings.search_step_deg;
  if (!args.coarse_gates.empty()) cs.lidar.coarse_gates = args.coarse_gates;
  if (args.rematch_deg != 0) {
    cs.rematch_deg = args.rematch_deg;
    cs.rematch_direction_deg = 5 * args.rematch_deg;
  }
  if (args.stereo_yaw >= 0) cs.lidar_estimates_stereo_yaw = args.stereo_yaw > 0;
  if (args.co_model_scale >= 0) {
    for (auto* v : {&cs.model_sigma_lidar_rot_deg, &cs.model_sigma_lidar_trans_m,
                    &cs.model_sigma_stereo_rot_deg, &cs.model_sigma_stereo_trans_m})
      for (double& x : *v) x *= args.co_model_scale;
    cs.model_sigma_stereo_scale *= args.co_model_scale;
  }
  return cs;
}

/// co / joint: both extrinsics; returns the LiDAR estimate.
Eigen::Isometry3d solveCo(const Args& args, const EvalData& d,
                          const LidarStereoSettings& solver_settings,
                          const std::vector<Keyframe*>& mwin, const Eigen::Isometry3d& T_init,
                          Trial& tr) {
  const CoCalibrationSettings cs = coSettings(args, solver_settings, d.co_refinement);
  const Eigen::Isometry3d T_rl_init = perturb(d.truth.T_right_left, tr.stereo.init);
  CoCalibrationResult r;
  if (args.mode == "joint") {
    JointCalibrationSettings jset;
    jset.co = cs;
    r = jointCalibrate(mwin, d.rig, T_init, T_rl_init, jset);
  } else {
    r = coCalibrate(mwin, d.rig, T_init, T_rl_init, cs);
  }
  tr.converged = r.converged;
  tr.iterations = r.rounds;
  tr.rematches = r.rematches;
  tr.yaw_handovers = r.yaw_handovers;
  tr.lidar_first = r.lidar_first ? 1 : 0;
  tr.stereo_scale = r.lidar.stereo_scale;
  tr.stereo_scale_sigma = std::sqrt(r.lidar.stereo_scale_variance);
  tr.halves = r.lidar.halves;
  tr.lidar_weakest = r.lidar.weakest();
  tr.stereo_weakest = r.stereo.weakest();
  tr.stage_seconds = {{"photometric", r.seconds_photometric},
                      {"stereo_cloud", r.seconds_stereo_cloud},
                      {"lidar_stereo", r.seconds_lidar}};
  // A placeholder covariance (singular information) is no claim: NaN, left out of the NEES.
  tr.lidar.cov = r.lidar.covariance_known ? r.lidar.covariance : Matrix6d::Constant(std::nan(""));
  tr.lidar.cov_stat = r.lidar.covariance_known ? r.lidar.covariance_statistical : tr.lidar.cov;
  tr.lidar.bias = r.lidar.bias_sensitivity;
  tr.stereo.cov =
      r.stereo.covariance_known ? r.stereo.covariance : Matrix6d::Constant(std::nan(""));
  tr.stereo.err = poseError(r.stereo.T_right_left, d.truth.T_right_left);
  tr.message = r.message;
  tr.brightness = r.stereo.brightness;
  return r.lidar.T_cam_lidar;
}

/// stereo: the left-right photometric solve with the (possibly perturbed) LiDAR extrinsic given.
void solveStereo(const Args& args, const EvalData& d, const std::vector<const Keyframe*>& window,
                 const Eigen::Isometry3d& T_init, Trial& tr) {
  PhotometricSettings ps;
  if (args.smooth_keypoints_px >= 0) ps.smooth_depth_radius_px = args.smooth_keypoints_px;
  if (args.depth_prior >= 0) ps.depth_prior_sigma = args.depth_prior;
  // With free depth the given LiDAR extrinsic's uncertainty is also the prior of its error as
  // a nuisance of the key points' depths.
  ps.lidar_error_sigma_rot_deg = args.lidar_sigma_deg;
  ps.lidar_error_sigma_trans_m = args.lidar_sigma_m;
  PhotometricResult r =
      solvePhotometric(window, d.rig, T_init, perturb(d.truth.T_right_left, tr.stereo.init), ps);
  if (args.lidar_sigma_deg > 0 || args.lidar_sigma_m > 0) {
    Matrix6d P = Matrix6d::Zero();
    addAxisVariances(&P, {args.lidar_sigma_deg, args.lidar_sigma_deg, args.lidar_sigma_deg},
                     {args.lidar_sigma_m, args.lidar_sigma_m, args.lidar_sigma_m});
    addLidarUncertainty(&r, P);
  }
  tr.converged = r.converged;
  tr.iterations = r.iterations;
  // A solve that ended before its covariance (too few key points, ...) has none: NaN, left out
  // of the NEES, as on the LiDAR side.
  tr.stereo.cov = r.covariance_known ? r.covariance : Matrix6d::Constant(std::nan(""));
  tr.stereo.err = poseError(r.T_right_left, d.truth.T_right_left);
  if (std::getenv("TESCALIB_DEBUG"))
    std::fprintf(stderr, "photo-consistency ratio %.3f over %d key points\n", r.consistency_ratio,
                 r.inliers);
  tr.stereo_weakest = r.weakest();
  tr.message = r.message;
  tr.brightness = r.brightness;
  if (!r.lidar_error.isZero()) tr.lidar_error_found = r.lidar_error;
}

/// stereo with the features method: R and the baseline direction from left-right feature matches,
/// the length kept at the (perturbed) guess'; no covariance over all six axes (the length has
/// none), so no NEES.
void solveStereoFeatures(const EvalData& d, const std::vector<const Keyframe*>& window, Trial& tr) {
  const FeatureStereoResult r =
      estimateStereoFromFeatures(window, d.rig, perturb(d.truth.T_right_left, tr.stereo.init));
  tr.converged = r.ok;
  tr.stereo.cov = Matrix6d::Constant(std::nan(""));
  tr.stereo.err = poseError(r.T_right_left, d.truth.T_right_left);
  const Eigen::Vector3d dir = r.T_right_left.translation().normalized(),
                        dir_gt = d.truth.T_right_left.translation().normalized();
  if (std::getenv("TESCALIB_DEBUG"))
    std::fprintf(stderr,
                 "features: %d matches, %d inliers, rms %.3f px, sigma %.4f deg / direction %.3f "
                 "deg; direction error %.3f deg; %.2f s %s\n",
                 r.matches, r.inliers, r.rms_px, r.sigma_rot_deg, r.sigma_direction_deg,
                 std::acos(std::min(1.0, dir.dot(dir_gt))) * kDegPerRad, r.seconds,
                 r.message.c_str());
  tr.message = r.message;
}

/// lidar_stereo with the tescalib method; returns the estimate.
Eigen::Isometry3d solveLidar(const LidarStereoSettings& solver_settings,
                             const std::vector<const Keyframe*>& window,
                             const Eigen::Isometry3d& T_init, Trial& tr) {
  const LidarStereoResult r = solveLidarStereoSearch(window, T_init, solver_settings);
  tr.converged = r.converged;
  tr.search_starts = r.search_starts;
  tr.iterations = r.iterations;
  tr.lidar.cov = r.covariance_known ? r.covariance : Matrix6d::Constant(std::nan(""));
  tr.lidar.cov_stat = r.covariance_known ? r.covariance_statistical : tr.lidar.cov;
  tr.lidar.bias = r.bias_sensitivity;
  if (solver_settings.fine_gain_probe > 0 && r.covariance_known)
    tr.lidar.fixed_point_contraction = r.fixed_point_contraction;
  if (r.covariance_known) tr.lidar_cov_model = r.covariance_model;
  tr.halves = r.halves;
  tr.lidar_weakest = r.weakest();
  tr.message = r.message;
  if (solver_settings.estimate_stereo_scale) {
    tr.stereo_scale = r.stereo_scale;
    tr.stereo_scale_sigma = std::sqrt(r.stereo_scale_variance);
  }
  if (solver_settings.estimate_stereo_yaw) tr.stereo_yaw_deg = r.stereo_yaw_rad * kDegPerRad;
  // Measured only where the fine stage had residuals (sigma 0: not measured; NaN, JSON's null).
  if (solver_settings.measure_disparity_offset && !solver_settings.estimate_stereo_yaw &&
      r.disparity_offset_sigma_px > 0) {
    tr.disparity_offset_px = r.disparity_offset_px;
    tr.disparity_offset_sigma_px = r.disparity_offset_sigma_px;
    tr.disparity_offset_used = disparityOffsetWidensBias(r, solver_settings);
  }
  return r.T_cam_lidar;
}

}  // namespace

namespace {

/// Trial `t`'s initial guesses (seeded by --seed and t); returns the initial T_cam_lidar.
Eigen::Isometry3d drawInitialGuess(const Args& args, int t, const EvalData& d, Trial* tr) {
  tr->seed = args.seed * 1000003ULL + t;
  std::mt19937_64 rng(tr->seed);
  const bool stereo_mode = args.mode == "stereo";
  const bool co_mode = args.mode == "co" || args.mode == "joint";
  const Vector6d main_delta =
      randomPerturbation(args.init_rot_deg / kDegPerRad, args.init_trans_m, rng);
  if (co_mode) {
    tr->lidar.init = main_delta;
    tr->stereo.init =
        randomPerturbation(args.init_stereo_rot_deg / kDegPerRad, args.init_stereo_trans_m, rng);
  } else if (stereo_mode) {
    tr->stereo.init = main_delta;
    tr->lidar.init = randomPerturbation(args.lidar_rot_deg / kDegPerRad, args.lidar_trans_m, rng);
  } else {
    tr->lidar.init = main_delta;
  }
  // The extrinsic the mode does not estimate is given: its error is where it was put.
  if (stereo_mode) tr->lidar.estimated = false, tr->lidar.err = tr->lidar.init;
  if (!stereo_mode && !co_mode) tr->stereo.estimated = false;
  return perturb(d.truth.T_cam_lidar, tr->lidar.init);
}

/// The trial's window (its keyframes in `mwin`, read-only in the result) with per-trial meshes,
/// view-filtered with the initial guess (never the ground truth); sets the preprocessing time.
std::vector<const Keyframe*> prepareWindow(const Args& args, int t, const Eigen::Isometry3d& T_init,
                                           EvalData* dp, Trial* tr, std::vector<Keyframe*>* mwin) {
  EvalData& d = *dp;
  const auto t_pre = Clock::now();
  const LidarMeshSettings ms = meshSettingsForView(d.rig, T_init, d.kfs);
  tr->window_index = static_cast<int>(t % d.n_windows);
  const size_t first = tr->window_index * d.window_size;
  double window_stereo_seconds = 0;
  for (size_t k = first; k < first + d.window_size; ++k) {
    mwin->push_back(&d.keyframes[k]);
    if (k < d.kf_stereo_seconds.size()) window_stereo_seconds += d.kf_stereo_seconds[k];
  }
  // Co-calibration re-rectifies the keyframes' clouds in place and keeps its SGBM matches to
  // re-triangulate them: each trial starts from none, as if it were the only one (otherwise a
  // trial's start depended on the trials before it and --first-trial did not reproduce it).
  if (args.mode == "co" || args.mode == "joint")
    for (Keyframe* kf : *mwin) {
      kf->stereo = StereoCloud{};
      kf->stereo_matched = StereoCloud{};
      kf->T_right_left_used = kf->T_right_left_matched = Eigen::Isometry3d::Identity();
    }
  std::vector<const Keyframe*> window;
  LidarMeshSettings ms_one = ms;
  ms_one.threads = 1;  // one keyframe per core instead
  std::vector<Keyframe*>& w = *mwin;
  parallelFor(static_cast<int>(w.size()), resolveThreads(ms.threads),
              [&](int k) { w[k]->mesh = buildLidarMesh(w[k]->scan, ms_one); });
  for (Keyframe* kfp : w) {
    if (t == args.first_trial)
      std::printf("  keyframe %zu: %zu LiDAR faces in view\n", window.size(),
                  kfp->mesh.faces.size());
    window.push_back(kfp);
  }
  tr->preprocess =
      std::chrono::duration<double>(Clock::now() - t_pre).count() + window_stereo_seconds;
  return window;
}

/// The mode's and method's solve; returns the LiDAR estimate (the initial guess where the mode
/// does not estimate it). A solver that throws fails its trial, not the run.
Eigen::Isometry3d solveTrial(const Args& args, const EvalData& d,
                             const LidarStereoSettings& solver_settings,
                             const std::vector<Keyframe*>& mwin,
                             const std::vector<const Keyframe*>& window,
                             const Eigen::Isometry3d& T_init, Trial& tr) {
  try {
    if (args.mode == "co" || args.mode == "joint")
      return solveCo(args, d, solver_settings, mwin, T_init, tr);
    if (args.mode == "stereo") {
      if (args.method == "features")
        solveStereoFeatures(d, window, tr);
      else
        solveStereo(args, d, window, T_init, tr);
      return T_init;
    }
    if (args.method == "tescalib") return solveLidar(solver_settings, window, T_init, tr);
    const GicpBaselineResult r = solveGicpBaseline(window, T_init);
    tr.converged = r.converged;
    tr.lidar.cov = Matrix6d::Constant(std::nan(""));
    return r.T_cam_lidar;
  } catch (const std::exception& ex) {
    // The estimates stay where they started, with no covariance (left out of the NEES).
    tr.converged = false;
    tr.message = std::string("the solve failed: ") + ex.what();
    tr.lidar.cov = tr.lidar.cov_stat = Matrix6d::Constant(std::nan(""));
    if (tr.stereo.estimated) {
      tr.stereo.err = tr.stereo.init;
      tr.stereo.cov = Matrix6d::Constant(std::nan(""));
    }
    return T_init;
  }
}

}  // namespace

Trial runTrial(const Args& args, int t, const LidarStereoSettings& solver_settings, EvalData* dp) {
  const EvalData& d = *dp;
  Trial tr;
  const bool stereo_mode = args.mode == "stereo";
  const bool co_mode = args.mode == "co" || args.mode == "joint";
  const Eigen::Isometry3d T_init = drawInitialGuess(args, t, d, &tr);
  std::vector<Keyframe*> mwin;
  const std::vector<const Keyframe*> window = prepareWindow(args, t, T_init, dp, &tr, &mwin);
  const auto t_solve = Clock::now();
  const Eigen::Isometry3d T_est = solveTrial(args, d, solver_settings, mwin, window, T_init, tr);
  tr.solve = std::chrono::duration<double>(Clock::now() - t_solve).count();
  ExtrinsicOutcome& est = stereo_mode ? tr.stereo : tr.lidar;
  if (!stereo_mode) tr.lidar.err = poseError(T_est, d.truth.T_cam_lidar);
  if (args.method == "tescalib") {
    // NaN (left out of the means) when a covariance is not positive definite.
    tr.nees = nees(est.err, est.cov);
    if (tr.lidar_cov_model.allFinite()) tr.nees_model = nees(est.err, tr.lidar_cov_model);
    if (co_mode)  // mean of both extrinsics' 6-DoF NEES
      tr.nees = 0.5 * (tr.nees + nees(tr.stereo.err, tr.stereo.cov));
  }
  return tr;
}

void printTrialHeader() {
  std::cout << " trial  conv  init(deg,m)    err rot [x y z] deg          err trans [x y z] cm"
               "        sigma(deg,cm)   iters  prep(s) solve(s)\n";
}

namespace {
/// Which success threshold an extrinsic missed: "LiDAR 3.23 cm" ("" when it succeeded).
std::string missed(const char* name, const ExtrinsicOutcome& o) {
  if (o.success()) return "";
  const double rot = o.err.head<3>().norm() * kDegPerRad, trans = o.err.tail<3>().norm() * 100;
  char buf[96];
  if (rot >= 0.2 && trans >= 3.0)
    std::snprintf(buf, sizeof buf, "%s %.3f deg, %.2f cm", name, rot, trans);
  else if (rot >= 0.2)
    std::snprintf(buf, sizeof buf, "%s %.3f deg", name, rot);
  else
    std::snprintf(buf, sizeof buf, "%s %.2f cm", name, trans);
  return buf;
}
}  // namespace

void printTrial(const Args& args, int t, const Trial& tr) {
  const bool stereo_mode = args.mode == "stereo";
  const bool co_mode = args.mode == "co" || args.mode == "joint";
  const ExtrinsicOutcome& est = stereo_mode ? tr.stereo : tr.lidar;
  const Vector6d& e = est.err;
  // A failed trial says which threshold (0.2 deg, 3 cm) it missed, then the solver's message.
  std::string fail = missed(stereo_mode ? "stereo" : "LiDAR", est);
  if (co_mode) {
    const std::string s = missed("stereo", tr.stereo);
    fail += fail.empty() || s.empty() ? s : "; " + s;
  }
  if (!fail.empty()) fail = " FAIL (" + fail + ")" + (tr.message.empty() ? "" : " " + tr.message);
  std::printf(
      " %4d   %s   %4.2f/%4.2f  [%7.4f %7.4f %7.4f]  [%7.3f %7.3f %7.3f]  %6.3f/%6.2f  %4d  "
      "%6.2f  %6.2f %s\n",
      t, tr.converged ? "yes" : " no", est.init.head<3>().norm() * kDegPerRad,
      est.init.tail<3>().norm(), e[0] * kDegPerRad, e[1] * kDegPerRad, e[2] * kDegPerRad,
      e[3] * 100, e[4] * 100, e[5] * 100,
      std::sqrt(est.cov.topLeftCorner<3, 3>().trace() / 3) * kDegPerRad,
      std::sqrt(est.cov.bottomRightCorner<3, 3>().trace() / 3) * 100, tr.iterations, tr.preprocess,
      tr.solve, fail.c_str());
  if (co_mode) {
    const Vector6d& es = tr.stereo.err;
    std::printf(
        "        stereo  %4.2f/%4.2f  [%7.4f %7.4f %7.4f]  [%7.3f %7.3f %7.3f]  %6.3f/%6.2f\n",
        tr.stereo.init.head<3>().norm() * kDegPerRad, tr.stereo.init.tail<3>().norm(),
        es[0] * kDegPerRad, es[1] * kDegPerRad, es[2] * kDegPerRad, es[3] * 100, es[4] * 100,
        es[5] * 100, std::sqrt(tr.stereo.cov.topLeftCorner<3, 3>().trace() / 3) * kDegPerRad,
        std::sqrt(tr.stereo.cov.bottomRightCorner<3, 3>().trace() / 3) * 100);
  }
}

}  // namespace tescalib::eval
