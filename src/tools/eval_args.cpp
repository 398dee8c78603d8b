#include "eval_args.h"

#include <cstdint>
#include <iostream>
#include <limits>
#include <string>

#include "cli.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib::eval {

void usage() {
  std::cout << "usage: rosrun tescalib tescalib_eval --sequences DIR[,DIR...]\n"
               "         [--mode lidar_stereo|stereo|co|joint]\n"
               "         [--method tescalib|pcl_gicp|features] [--trials N] [--init-rot-deg R]\n"
               "         [--init-trans-m T] [--init-stereo-rot-deg R] [--init-stereo-trans-m T]\n"
               "         [--seed S] [--window W] [--json FILE] [--stages coarse,fine]\n"
               "         [--lidar-rot-deg R --lidar-trans-m T] [--windows first|disjoint]\n"
               "         [--cov-cells XxY] [--cov-model-scale K] [--first-trial K]\n"
               "         [--co-model-scale K] [--smooth-keypoints PX] [--stereo-yaw 0|1]\n"
               "         [--stereo-scale 0|1] [--check-halves 0|1] [--measure-offset 0|1]\n"
               "         [--coarse-nuisances 0|1] [--coarse-gates M,M,...] [--search-deg D]\n"
               "         [--lidar-sigma DEG,M] [--refine-iterations N]\n"
               "         [--refine-smoothed-rounds N] [--deskew 0|1] [--keep-rings N]\n"
               "         [--depth-prior SIGMA] [--free-depth-rounds N] [--consistent-sample 0|1]\n"
               "         [--rematch-deg X] [--lidar-first 0|1] [--features 0|1]\n"
               "         [--propagate-stereo 0|1]\n"
               "Modes: lidar_stereo (T_cam_lidar estimated, stereo at ground truth), stereo\n"
               "(T_right_left estimated from the --init sizes, LiDAR at ground truth or\n"
               "perturbed by --lidar-*), co (both: LiDAR from the --init sizes, stereo from the\n"
               "--init-stereo sizes), joint (as co, one Ceres problem over both extrinsics).\n"
               "Sequences are KITTI folders (odometry or raw layout) sharing one calibration\n"
               "(real, or written by tescalib_simulate). Keyframes are frames >= 0.5 s apart;\n"
               "the window holds the first W.\n"
               "A trial perturbs the ground truth by exactly R deg about a random axis and T m\n"
               "in a random direction and succeeds when the error is below 0.2 deg and 3 cm.\n"
               "Defaults: --mode lidar_stereo --method tescalib --trials 10 --init-rot-deg 3\n"
               "--init-trans-m 0.3 --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --seed 1\n"
               "--window 20 --windows first (doc/evaluation.md has the conventions and the\n"
               "JSON).\n"
               "--stages coarse,fine: lidar_stereo mode: the LiDAR-stereo stages to run (coarse,\n"
               "fine or both).\n"
               "--cov-cells XxY: image cells per keyframe of the LiDAR-stereo covariance's\n"
               "sandwich estimator (LidarStereoSettings::cov_cells_x/y; default 8x3).\n"
               "--cov-model-scale K: scales the LiDAR-stereo covariance's model error (the\n"
               "common biases and per-axis floor; default 1, 0: without it).\n"
               "--windows disjoint splits all keyframes into consecutive windows of W and trial\n"
               "t uses window t mod (number of windows): independent windows, so mean NEES means\n"
               "something.\n"
               "--smooth-keypoints PX: full-resolution photometric key points only where the\n"
               "LiDAR depth is smooth within PX pixels\n"
               "(PhotometricSettings::smooth_depth_radius_px; 0: off).\n"
               "--depth-prior SIGMA: photometric key points' depth free at full resolution with\n"
               "a log-depth prior of SIGMA (PhotometricSettings::depth_prior_sigma; 0: the\n"
               "LiDAR's). (co: the prior of the rounds with free depth,\n"
               "CoCalibrationSettings::free_depth_prior_sigma)\n"
               "--free-depth-rounds N: co: photometric solves of rounds 1..N with free key point\n"
               "depth.\n"
               "--lidar-first 0|1: co: the LiDAR-first fallback (CoCalibrationSettings::\n"
               "lidar_first_fallback; default 0); its LiDAR-stereo search follows --search-deg.\n"
               "--features 0|1: co: round 1 from the stereo pair of left-right feature matches,\n"
               "LiDAR first (CoCalibrationSettings::stereo_from_features); its search follows\n"
               "--search-deg.\n"
               "--propagate-stereo 0|1: co: the stereo pair's uncertainty in the LiDAR\n"
               "covariance (CoCalibrationSettings::propagate_stereo_into_lidar; default 1).\n"
               "--rematch-deg X: co: SGBM matches again beyond X deg about x/z (and 5 X of\n"
               "baseline direction) from its last matches, re-triangulates below (< 0: always\n"
               "matches again).\n"
               "--stereo-yaw 0|1: the LiDAR-stereo solve also estimates the right camera's yaw\n"
               "relative to the clouds' rectification (a disparity offset; LidarStereoSettings::\n"
               "estimate_stereo_yaw, co: CoCalibrationSettings::lidar_estimates_stereo_yaw).\n"
               "--stereo-scale 0|1: lidar_stereo mode: the solve also estimates a scale of the\n"
               "stereo clouds (LidarStereoSettings::estimate_stereo_scale; always on in co).\n"
               "--refine-iterations N: rounds of the stereo clouds' disparity refinement\n"
               "(StereoSettings::refinement.iterations; 0 keeps SGBM's disparities; default 2 in\n"
               "lidar_stereo mode, 1 for the clouds co and joint match, coStereoCloudSettings).\n"
               "--refine-smoothed-rounds N: of those rounds, the first N take the smoothed\n"
               "gradient (DisparityRefinementSettings::smoothed_gradient_rounds; default 1 in\n"
               "lidar_stereo mode, 0 in co and joint).\n"
               "--deskew 0|1: motion-compensate each keyframe's scan to the camera trigger with\n"
               "the velocity registered against the sequence's next frame (default: on for KITTI\n"
               "raw recordings and tescalib_simulate --lidar-sweep 1 output; off for KITTI\n"
               "odometry sequences, which KITTI compensated, and the generator's default\n"
               "output).\n"
               "--keep-rings N: keep every Nth laser ring of each scan (a sparser LiDAR from the\n"
               "same drive: 64 rings with N = 2 are 32, with N = 4 16 rings about 1.7 deg\n"
               "apart).\n"
               "--consistent-sample 0|1: draw each mesh's faces by their place in the range\n"
               "image (LidarMeshSettings::consistent_sample; default 0: evenly strided over the\n"
               "faces in view, which moves with the initial guess' view cone).\n"
               "--check-halves 0|1: the split-window check of the LiDAR-stereo noise model after\n"
               "a converged solve (LidarStereoSettings::check_window_halves; on by default).\n"
               "--measure-offset 0|1: measure the disparity offset the LiDAR-stereo residuals\n"
               "show and widen the covariance's bias term with it\n"
               "(LidarStereoSettings::measure_disparity_offset; on by default).\n"
               "--coarse-nuisances 0|1: the LiDAR-stereo coarse stage also estimates the clouds'\n"
               "scale and yaw where they are estimated (co; LidarStereoSettings::\n"
               "coarse_estimates_stereo_nuisances; off by default: only the fine stage does).\n"
               "--coarse-gates M,M,...: the coarse stage's 6-D association gates, one stage each\n"
               "(LidarStereoSettings::coarse_gates; default 2,1,0.5; co and joint: their\n"
               "LiDAR-stereo solves).\n"
               "--search-deg D: lidar_stereo mode (co: the LiDAR-first fallback's solve): a\n"
               "solve that does not converge is tried again from the start turned by +-D deg\n"
               "about the camera's x and y axes, 8 more starts\n"
               "(LidarStereoSettings::search_step_deg; default 10; 0: off).\n"
               "--lidar-sigma DEG,M: stereo mode: the given LiDAR extrinsic's 1-sigma per axis;\n"
               "the left-right covariance adds what it does to the key points' depth (default 0:\n"
               "exact); with --depth-prior its error is also a nuisance of the key points'\n"
               "depths, with this prior (PhotometricSettings::lidar_error_sigma_*).\n";
}

bool parse(int argc, char** argv, Args* a) {
  auto option = [a](const std::string& k, const std::string& v) {
    if (k == "--sequences")
      a->sequences = cli::splitList(v);
    else if (k == "--mode")
      a->mode = v;
    else if (k == "--method")
      a->method = v;
    else if (k == "--trials")
      a->trials = cli::toInt(v);
    else if (k == "--first-trial") {
      a->first_trial = cli::toInt(v);
      if (a->first_trial < 0) throw std::invalid_argument(v);
    } else if (k == "--init-rot-deg")
      a->init_rot_deg = cli::toNonNegative(v);
    else if (k == "--init-trans-m")
      a->init_trans_m = cli::toNonNegative(v);
    else if (k == "--init-stereo-rot-deg")
      a->init_stereo_rot_deg = cli::toNonNegative(v);
    else if (k == "--init-stereo-trans-m")
      a->init_stereo_trans_m = cli::toNonNegative(v);
    else if (k == "--seed")
      a->seed = cli::toSeed(v);
    else if (k == "--window")
      a->window = cli::toInt(v);
    else if (k == "--json")
      a->json = v;
    else if (k == "--stages")
      a->stages = v;
    else if (k == "--lidar-rot-deg")
      a->lidar_rot_deg = cli::toNonNegative(v);
    else if (k == "--lidar-trans-m")
      a->lidar_trans_m = cli::toNonNegative(v);
    else if (k == "--windows")
      a->windows = v;
    else if (k == "--cov-cells") {
      const auto x = v.find('x');
      if (x == std::string::npos) throw std::invalid_argument(v);
      a->cov_cells_x = cli::toInt(v.substr(0, x));
      a->cov_cells_y = cli::toInt(v.substr(x + 1));
      if (a->cov_cells_x < 1 || a->cov_cells_y < 1) throw std::invalid_argument(v);
    } else if (k == "--cov-model-scale")
      a->cov_model_scale = cli::toNonNegative(v);
    else if (k == "--smooth-keypoints") {
      a->smooth_keypoints_px = cli::toInt(v);
      if (a->smooth_keypoints_px < 0) throw std::invalid_argument(v);
    } else if (k == "--depth-prior")
      a->depth_prior = cli::toNonNegative(v);
    else if (k == "--free-depth-rounds") {
      a->free_depth_rounds = cli::toInt(v);
      if (a->free_depth_rounds < 0) throw std::invalid_argument(v);
    } else if (k == "--lidar-first")
      a->lidar_first = cli::toSwitch(v);
    else if (k == "--features")
      a->features = cli::toSwitch(v);
    else if (k == "--propagate-stereo")
      a->propagate_stereo = cli::toSwitch(v);
    else if (k == "--rematch-deg")
      a->rematch_deg = cli::toDouble(v);
    else if (k == "--co-model-scale")
      a->co_model_scale = cli::toNonNegative(v);
    else if (k == "--stereo-yaw")
      a->stereo_yaw = cli::toSwitch(v);
    else if (k == "--stereo-scale")
      a->stereo_scale = cli::toSwitch(v);
    else if (k == "--deskew")
      a->deskew = cli::toSwitch(v);
    else if (k == "--consistent-sample")
      a->consistent_sample = cli::toSwitch(v);
    else if (k == "--keep-rings") {
      a->keep_rings = cli::toInt(v);
      if (a->keep_rings < 1) throw std::invalid_argument(v);
    } else if (k == "--check-halves")
      a->check_halves = cli::toSwitch(v);
    else if (k == "--measure-offset")
      a->measure_offset = cli::toSwitch(v);
    else if (k == "--coarse-nuisances")
      a->coarse_nuisances = cli::toSwitch(v);
    else if (k == "--search-deg") {
      a->search_deg = cli::toNonNegative(v);
      if (a->search_deg > LidarStereoSettings::kMaxSearchStepDeg) throw std::invalid_argument(v);
    } else if (k == "--coarse-gates") {
      a->coarse_gates.clear();
      for (const auto& g : cli::splitList(v)) {
        a->coarse_gates.push_back(cli::toDouble(g));
        if (!(a->coarse_gates.back() > 0)) throw std::invalid_argument(v);
      }
      if (a->coarse_gates.empty()) throw std::invalid_argument(v);
    } else if (k == "--refine-smoothed-rounds") {
      a->refine_smoothed = cli::toInt(v);
      if (a->refine_smoothed < 0) throw std::invalid_argument(v);
    } else if (k == "--refine-iterations") {
      a->refine_iterations = cli::toInt(v);
      if (a->refine_iterations < 0) throw std::invalid_argument(v);
    } else if (k == "--lidar-sigma") {
      const auto parts = cli::splitList(v);
      if (parts.size() != 2) throw std::invalid_argument(v);
      a->lidar_sigma_deg = cli::toNonNegative(parts[0]);
      a->lidar_sigma_m = cli::toNonNegative(parts[1]);
    } else {
      return false;
    }
    return true;
  };
  if (!cli::parseOptions(argc, argv, "tescalib_eval", usage, option)) return false;
  for (const auto& stage : cli::splitList(a->stages))
    if (stage != "coarse" && stage != "fine") {
      std::cerr << "tescalib_eval: --stages takes coarse, fine or coarse,fine (got '" << a->stages
                << "')\n";
      return false;
    }
  if (cli::splitList(a->stages).empty()) {
    std::cerr << "tescalib_eval: --stages is empty\n";
    return false;
  }
  if (a->windows != "first" && a->windows != "disjoint") {
    std::cerr << "tescalib_eval: --windows must be first or disjoint\n";
    return false;
  }
  if (a->sequences.empty()) {
    std::cerr << "tescalib_eval: --sequences is required\n";
    return false;
  }
  if (a->mode != "lidar_stereo" && a->mode != "stereo" && a->mode != "co" && a->mode != "joint") {
    std::cerr << "tescalib_eval: unknown mode '" << a->mode
              << "' (the modes: lidar_stereo, stereo, co, joint)\n";
    return false;
  }
  // The JSON's folder is checked before the trials run, not after them.
  if (const std::string folder = cli::missingFolder(a->json); !folder.empty()) {
    std::cerr << "tescalib_eval: --json: the folder \"" << folder << "\" does not exist\n";
    return false;
  }
  if (a->method != "tescalib" && a->method != "pcl_gicp" && a->method != "features") {
    std::cerr << "tescalib_eval: unknown method '" << a->method
              << "' (tescalib, pcl_gicp, features)\n";
    return false;
  }
  if (a->method == "pcl_gicp" && a->mode != "lidar_stereo") {
    std::cerr << "tescalib_eval: --method pcl_gicp registers LiDAR scans to stereo clouds: it is "
                 "a baseline of --mode lidar_stereo only (not of "
              << a->mode << ")\n";
    return false;
  }
  if (a->method == "features" && a->mode != "stereo") {
    std::cerr << "tescalib_eval: --method features estimates the stereo pair from left-right "
                 "feature matches: it is a baseline of --mode stereo only (not of "
              << a->mode << ")\n";
    return false;
  }
  if (a->trials < 1 || a->window < 1) {
    std::cerr << "tescalib_eval: --trials and --window must be positive\n";
    return false;
  }
  // Trial t's seed is seed * 1000003 + t, written to the JSON: it must stay exact there (2^53).
  const uint64_t last_trial = uint64_t(a->first_trial) + uint64_t(a->trials);
  if (last_trial > uint64_t(std::numeric_limits<int>::max()) ||
      a->seed > ((1ULL << 53) - last_trial) / 1000003ULL) {
    std::cerr
        << "tescalib_eval: --seed (at most about 9007170000), --first-trial and --trials are too "
           "large: trial t's seed, seed * 1000003 + t, must stay below 2^53\n";
    return false;
  }
  // Options of one mode only are refused elsewhere rather than silently ignored.
  const bool lidar_options = a->lidar_rot_deg > 0 || a->lidar_trans_m > 0 ||
                             a->lidar_sigma_deg > 0 || a->lidar_sigma_m > 0;
  if (lidar_options && a->mode != "stereo") {
    std::cerr << "tescalib_eval: --lidar-rot-deg, --lidar-trans-m and --lidar-sigma are options "
                 "of --mode stereo (the LiDAR extrinsic the left-right solve is given), not of "
              << a->mode << "\n";
    return false;
  }
  if (a->stages != "coarse,fine" && a->mode != "lidar_stereo") {
    std::cerr << "tescalib_eval: --stages is an option of --mode lidar_stereo (co and joint run "
                 "their own stages), not of "
              << a->mode << "\n";
    return false;
  }
  return true;
}

}  // namespace tescalib::eval
