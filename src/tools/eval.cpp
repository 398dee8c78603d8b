// tescalib_eval: runs the calibration on KITTI-layout sequences from perturbed initial guesses
// and measures it against the ground truth (contract: DESIGN.md, "Evaluation protocol").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/co_calibration.h"
#include "tescalib/core/error.h"
#include "tescalib/core/geometry.h"
#include "tescalib/core/gicp_baseline.h"
#include "tescalib/core/joint_calibration.h"
#include "tescalib/core/keyframe.h"
#include "tescalib/core/kitti_reader.h"
#include "tescalib/core/lidar_stereo_solver.h"
#include "tescalib/core/parallel.h"
#include "tescalib/core/photometric_solver.h"
#include "tescalib/core/scan_motion.h"

#include "cli.h"

using namespace tescalib;
using Clock = std::chrono::steady_clock;

namespace {

struct Args {
  std::vector<std::string> sequences;
  std::string mode = "lidar_stereo";
  std::string method = "tescalib";
  int trials = 10;
  int first_trial = 0;  ///< runs trials first_trial .. first_trial + trials - 1
  double init_rot_deg = 3.0, init_trans_m = 0.3;
  double init_stereo_rot_deg = 1.0, init_stereo_trans_m = 0.1;
  double lidar_rot_deg = 0.0, lidar_trans_m = 0.0;  ///< stereo mode: LiDAR extrinsic error
  uint64_t seed = 1;
  int window = 20;
  std::string json;
  std::string stages = "coarse,fine";
  int cov_cells_x = -1, cov_cells_y = -1;  ///< -1: the solver default
  int smooth_keypoints_px = -1;  ///< photometric smooth_depth_radius_px; -1: the solver default
  double depth_prior = -1;       ///< photometric depth_prior_sigma; < 0: the solver default
  /// stereo mode: 1-sigma per axis of the given LiDAR extrinsic (deg, m), propagated into the
  /// left-right covariance (addLidarUncertainty); 0: taken as exact.
  double lidar_sigma_deg = 0, lidar_sigma_m = 0;
  int free_depth_rounds = -1;    ///< co: CoCalibrationSettings::free_depth_rounds; < 0: default
  double rematch_deg = 0;        ///< co: CoCalibrationSettings::rematch_deg; 0: the default
  double co_model_scale = -1;  ///< scales CoCalibrationSettings::model_sigma_*; -1: as is
  int stereo_yaw = -1;  ///< LiDAR-stereo estimates the right camera's yaw: 0/1; -1: the default
  int stereo_scale = -1;  ///< LiDAR-stereo mode estimates the clouds' scale: 0/1; -1: the default
  int check_halves = -1;  ///< LidarStereoSettings::check_window_halves: 0/1; -1: the default
  int measure_offset = -1;  ///< LidarStereoSettings::measure_disparity_offset: 0/1; -1: the default
  int coarse_nuisances = -1;   ///< LidarStereoSettings::coarse_estimates_stereo_nuisances: 0/1
  std::vector<double> coarse_gates;  ///< LidarStereoSettings::coarse_gates; empty: the default
  double search_deg = -1;  ///< LidarStereoSettings::search_step_deg; < 0: the default
  int refine_iterations = -1;  ///< DisparityRefinementSettings::iterations; -1: the default
  int refine_smoothed = -1;    ///< DisparityRefinementSettings::smoothed_gradient_rounds
  /// De-skew the scans with the motion registered against a neighbouring frame: 0/1; -1: when
  /// the sequence's scans are swept (sweptScans).
  int deskew = -1;
  double cov_model_scale = -1;             ///< scales the solver's model-error sigmas (0: none)
  std::string windows = "first";  ///< first: the first W keyframes; disjoint: every W in turn
};

void usage() {
  std::cout
      << "usage: rosrun tescalib tescalib_eval --sequences DIR[,DIR...]\n"
         "         [--mode lidar_stereo|stereo|co|joint]\n"
         "         [--method tescalib|pcl_gicp] [--trials N] [--init-rot-deg R] [--init-trans-m "
         "T]\n"
         "         [--init-stereo-rot-deg R] [--init-stereo-trans-m T] [--seed S] [--window W]\n"
         "         [--json FILE] [--stages coarse,fine] [--lidar-rot-deg R --lidar-trans-m T]\n"
         "         [--windows first|disjoint] [--cov-cells XxY] [--cov-model-scale K] "
         "[--first-trial K]\n"
         "         [--co-model-scale K] [--smooth-keypoints PX] [--stereo-yaw 0|1]\n"
         "         [--stereo-scale 0|1] [--check-halves 0|1] [--measure-offset 0|1]\n"
         "         [--coarse-nuisances 0|1] [--coarse-gates M,M,...] [--search-deg D]\n"
         "         [--lidar-sigma DEG,M]\n"
         "         [--refine-iterations N] [--refine-smoothed-rounds N]\n"
         "         [--deskew 0|1] [--depth-prior SIGMA] [--free-depth-rounds N] [--rematch-deg X]\n"
         "Modes: lidar_stereo (T_cam_lidar estimated, stereo at ground truth), stereo "
         "(T_right_left\n"
         "estimated from the --init sizes, LiDAR at ground truth or perturbed by --lidar-*), co\n"
         "(both: LiDAR from the --init sizes, stereo from the --init-stereo sizes), joint (as co,\n"
         "one Ceres problem over both extrinsics).\n"
         "Sequences are KITTI folders (odometry or raw layout) sharing one calibration (real, or\n"
         "written by tescalib_simulate). Keyframes are frames >= 0.5 s apart; the window holds\n"
         "the first W.\n"
         "A trial perturbs the ground truth by exactly R deg about a random axis and T m in a "
         "random\n"
         "direction and succeeds when the error is below 0.2 deg and 3 cm.\n"
         "--windows disjoint splits all keyframes into consecutive windows of W and trial t uses\n"
         "window t mod (number of windows): independent windows, so mean NEES means something.\n"
         "--smooth-keypoints PX: full-resolution photometric key points only where the LiDAR "
         "depth\n"
         "is smooth within PX pixels (PhotometricSettings::smooth_depth_radius_px; 0: off).\n"
         "--depth-prior SIGMA: photometric key points' depth free at full resolution with a\n"
         "log-depth prior of SIGMA (PhotometricSettings::depth_prior_sigma; 0: the LiDAR's).\n"
         "(co: the prior of the rounds with free depth, "
         "CoCalibrationSettings::free_depth_prior_sigma)\n"
         "--free-depth-rounds N: co: photometric solves of rounds 1..N with free key point depth.\n"
         "--rematch-deg X: co: SGBM matches again beyond X deg about x/z (and 5 X of baseline\n"
         "direction) from its last matches, re-triangulates below (< 0: always matches again).\n"
         "--stereo-yaw 0|1: the LiDAR-stereo solve also estimates the right camera's yaw relative\n"
         "to the clouds' rectification (a disparity offset; LidarStereoSettings::\n"
         "estimate_stereo_yaw, co: CoCalibrationSettings::lidar_estimates_stereo_yaw).\n"
         "--stereo-scale 0|1: lidar_stereo mode: the solve also estimates a scale of the stereo\n"
         "clouds (LidarStereoSettings::estimate_stereo_scale; always on in co).\n"
         "--refine-iterations N: rounds of the stereo clouds' disparity refinement\n"
         "(StereoSettings::refinement.iterations; 0 keeps SGBM's disparities; default 2 in\n"
         "lidar_stereo mode, 1 for the clouds co and joint match, coStereoCloudSettings).\n"
         "--refine-smoothed-rounds N: of those rounds, the first N take the smoothed gradient\n"
         "(DisparityRefinementSettings::smoothed_gradient_rounds; default 1 in lidar_stereo\n"
         "mode, 0 in co and joint).\n"
         "--deskew 0|1: motion-compensate each keyframe's scan to the camera trigger with the\n"
         "velocity registered against the sequence's next frame (default: on for KITTI raw\n"
         "recordings and tescalib_simulate --lidar-sweep 1 output; off for KITTI odometry\n"
         "sequences, which KITTI compensated, and the generator's default output).\n"
         "--check-halves 0|1: the split-window check of the LiDAR-stereo noise model after a\n"
         "converged solve (LidarStereoSettings::check_window_halves; on by default).\n"
         "--measure-offset 0|1: measure the disparity offset the LiDAR-stereo residuals show and\n"
         "widen the covariance's bias term with it "
         "(LidarStereoSettings::measure_disparity_offset;\n"
         "on by default).\n"
         "--coarse-nuisances 0|1: the LiDAR-stereo coarse stage also estimates the clouds' scale\n"
         "and yaw where they are estimated (co; LidarStereoSettings::\n"
         "coarse_estimates_stereo_nuisances; off by default: only the fine stage does).\n"
         "--coarse-gates M,M,...: the coarse stage's 6-D association gates, one stage each\n"
         "(LidarStereoSettings::coarse_gates; default 2,1,0.5).\n"
         "--search-deg D: lidar_stereo mode: a solve that does not converge is tried again from\n"
         "the start turned by +-D deg about the camera's x and y axes, 8 more starts\n"
         "(LidarStereoSettings::search_step_deg; default 10; 0: off).\n"
         "--lidar-sigma DEG,M: stereo mode: the given LiDAR extrinsic's 1-sigma per axis; the\n"
         "left-right covariance adds what it does to the key points' depth (default 0: exact);\n"
         "with --depth-prior its error is also a nuisance of the key points' depths, with this\n"
         "prior (PhotometricSettings::lidar_error_sigma_*).\n";
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
      a->trials = std::stoi(v);
    else if (k == "--first-trial")
      a->first_trial = std::stoi(v);
    else if (k == "--init-rot-deg")
      a->init_rot_deg = std::stod(v);
    else if (k == "--init-trans-m")
      a->init_trans_m = std::stod(v);
    else if (k == "--init-stereo-rot-deg")
      a->init_stereo_rot_deg = std::stod(v);
    else if (k == "--init-stereo-trans-m")
      a->init_stereo_trans_m = std::stod(v);
    else if (k == "--seed")
      a->seed = std::stoull(v);
    else if (k == "--window")
      a->window = std::stoi(v);
    else if (k == "--json")
      a->json = v;
    else if (k == "--stages")
      a->stages = v;
    else if (k == "--lidar-rot-deg")
      a->lidar_rot_deg = std::stod(v);
    else if (k == "--lidar-trans-m")
      a->lidar_trans_m = std::stod(v);
    else if (k == "--windows")
      a->windows = v;
    else if (k == "--cov-cells") {
      const auto x = v.find('x');
      if (x == std::string::npos) throw std::invalid_argument(v);
      a->cov_cells_x = std::stoi(v.substr(0, x));
      a->cov_cells_y = std::stoi(v.substr(x + 1));
    } else if (k == "--cov-model-scale")
      a->cov_model_scale = std::stod(v);
    else if (k == "--smooth-keypoints")
      a->smooth_keypoints_px = std::stoi(v);
    else if (k == "--depth-prior")
      a->depth_prior = std::stod(v);
    else if (k == "--free-depth-rounds")
      a->free_depth_rounds = std::stoi(v);
    else if (k == "--rematch-deg")
      a->rematch_deg = std::stod(v);
    else if (k == "--co-model-scale")
      a->co_model_scale = std::stod(v);
    else if (k == "--stereo-yaw")
      a->stereo_yaw = std::stoi(v);
    else if (k == "--stereo-scale")
      a->stereo_scale = std::stoi(v);
    else if (k == "--deskew")
      a->deskew = std::stoi(v);
    else if (k == "--check-halves")
      a->check_halves = std::stoi(v);
    else if (k == "--measure-offset")
      a->measure_offset = std::stoi(v);
    else if (k == "--coarse-nuisances")
      a->coarse_nuisances = std::stoi(v);
    else if (k == "--search-deg")
      a->search_deg = std::stod(v);
    else if (k == "--coarse-gates") {
      a->coarse_gates.clear();
      for (const auto& g : cli::splitList(v)) a->coarse_gates.push_back(std::stod(g));
      if (a->coarse_gates.empty()) throw std::invalid_argument(v);
    }
    else if (k == "--refine-smoothed-rounds") {
      a->refine_smoothed = std::stoi(v);
      if (a->refine_smoothed < 0) throw std::invalid_argument(v);
    } else if (k == "--refine-iterations") {
      a->refine_iterations = std::stoi(v);
      if (a->refine_iterations < 0) throw std::invalid_argument(v);
    } else if (k == "--lidar-sigma") {
      const auto parts = cli::splitList(v);
      if (parts.size() != 2) throw std::invalid_argument(v);
      a->lidar_sigma_deg = std::stod(parts[0]);
      a->lidar_sigma_m = std::stod(parts[1]);
      if (!(a->lidar_sigma_deg >= 0 && a->lidar_sigma_m >= 0)) throw std::invalid_argument(v);
    } else {
      return false;
    }
    return true;
  };
  if (!cli::parseOptions(argc, argv, "tescalib_eval", usage, option)) return false;
  if (a->windows != "first" && a->windows != "disjoint") {
    std::cerr << "tescalib_eval: --windows must be first or disjoint\n";
    return false;
  }
  if (a->sequences.empty()) {
    std::cerr << "tescalib_eval: --sequences is required\n";
    return false;
  }
  if (a->mode != "lidar_stereo" && a->mode != "stereo" && a->mode != "co" && a->mode != "joint") {
    std::cerr << "tescalib_eval: mode '" << a->mode
              << "' is not available in this build (available: lidar_stereo, stereo, co, joint)\n";
    return false;
  }
  if (a->method != "tescalib" && a->method != "pcl_gicp") {
    std::cerr << "tescalib_eval: unknown method '" << a->method << "' (tescalib, pcl_gicp)\n";
    return false;
  }
  if (a->method == "pcl_gicp" && a->mode != "lidar_stereo") {
    std::cerr << "tescalib_eval: --method pcl_gicp registers LiDAR scans to stereo clouds: it is "
                 "a baseline of --mode lidar_stereo only (not of "
              << a->mode << ")\n";
    return false;
  }
  if (a->trials < 1 || a->window < 1) {
    std::cerr << "tescalib_eval: --trials and --window must be positive\n";
    return false;
  }
  return true;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string jsonArray(const double* v, int n) {
  std::ostringstream o;
  o << std::setprecision(10) << "[";
  // Not-a-number (no covariance: a baseline without one, an extrinsic the mode does not
  // estimate) is JSON's null, never 0 (which would read as exact).
  for (int i = 0; i < n; ++i) {
    o << (i ? ", " : "");
    if (std::isfinite(v[i]))
      o << v[i];
    else
      o << "null";
  }
  o << "]";
  return o.str();
}

/// A number, or null when there is none (not a number).
std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o << std::setprecision(10) << v;
  return o.str();
}

struct ExtrinsicOutcome {
  /// false: the mode does not estimate this extrinsic (it is given: ground truth, or perturbed
  /// by --lidar-* in stereo mode); `err` is then the given value's error, and there is no
  /// covariance (null in the JSON).
  bool estimated = true;
  Vector6d init = Vector6d::Zero();
  Vector6d err = Vector6d::Zero();
  Matrix6d cov = Matrix6d::Identity();
  /// The covariance without the model error (LiDAR-stereo): what the window constrains.
  Matrix6d cov_stat = Matrix6d::Constant(std::nan(""));
  /// Pose shift per px of common disparity offset and per m of common LiDAR range offset.
  Eigen::Matrix<double, 6, 2> bias = Eigen::Matrix<double, 6, 2>::Constant(std::nan(""));
  bool success() const {
    return err.head<3>().norm() * kDegPerRad < 0.2 && err.tail<3>().norm() < 0.03;
  }
  std::string json() const {
    double ir[3], it[3], er[3], et[3], sr[3], st[3], c[36];
    for (int i = 0; i < 3; ++i) {
      ir[i] = init[i] * kDegPerRad, it[i] = init[3 + i];
      er[i] = err[i] * kDegPerRad, et[i] = err[3 + i];
      sr[i] = std::sqrt(cov(i, i)) * kDegPerRad, st[i] = std::sqrt(cov(3 + i, 3 + i));
    }
    for (int i = 0; i < 36; ++i) c[i] = cov(i / 6, i % 6);
    if (!estimated) {
      std::fill(std::begin(c), std::end(c), std::nan(""));
      std::fill(std::begin(sr), std::end(sr), std::nan(""));
      std::fill(std::begin(st), std::end(st), std::nan(""));
    }
    std::ostringstream o;
    o << "{\"estimated\": " << (estimated ? "true" : "false")
      << ", \"init_rot_deg\": " << jsonArray(ir, 3) << ", \"init_trans_m\": " << jsonArray(it, 3)
      << ", \"rot_err_deg\": " << jsonArray(er, 3) << ", \"trans_err_m\": " << jsonArray(et, 3)
      << ", \"sigma_rot_deg\": " << jsonArray(sr, 3) << ", \"sigma_trans_m\": " << jsonArray(st, 3)
      << ", \"covariance\": " << jsonArray(c, 36);
    if (cov_stat.allFinite()) {
      for (int i = 0; i < 3; ++i)
        sr[i] = std::sqrt(cov_stat(i, i)) * kDegPerRad, st[i] = std::sqrt(cov_stat(3 + i, 3 + i));
      o << ", \"sigma_statistical_rot_deg\": " << jsonArray(sr, 3)
        << ", \"sigma_statistical_trans_m\": " << jsonArray(st, 3);
      for (int i = 0; i < 36; ++i) c[i] = cov_stat(i / 6, i % 6);
      o << ", \"covariance_statistical\": " << jsonArray(c, 36);
    }
    if (bias.allFinite()) {
      double b[12];
      for (int i = 0; i < 12; ++i) b[i] = bias(i % 6, i / 6);
      o << ", \"bias_sensitivity_disparity_px\": " << jsonArray(b, 6)
        << ", \"bias_sensitivity_range_m\": " << jsonArray(b + 6, 6);
    }
    o << "}";
    return o.str();
  }
};

struct Trial {
  uint64_t seed = 0;
  bool converged = false;
  ExtrinsicOutcome lidar, stereo;
  double nees = std::nan("");
  double nees_model = std::nan("");  ///< NEES with the paper's covariance (lidar_stereo mode)
  Matrix6d lidar_cov_model = Matrix6d::Constant(std::nan(""));
  int window_index = 0;
  double preprocess = 0, solve = 0;
  int iterations = 0;        ///< solver iterations; co/joint: rounds
  int rematches = -1;        ///< co/joint: keyframe clouds matched again (SGBM)
  int yaw_handovers = -1;    ///< co: restarts at the LiDAR-stereo yaw (CoCalibrationResult)
  double stereo_scale = std::nan(""), stereo_scale_sigma = std::nan("");  ///< when estimated
  double stereo_yaw_deg = std::nan("");  ///< the clouds' yaw, when LiDAR-stereo mode estimates it
  double disparity_offset_px = std::nan("");  ///< LidarStereoResult::disparity_offset_px, measured
  double disparity_offset_sigma_px = std::nan("");
  bool disparity_offset_used = false;  ///< determined and beyond the model: the bias term uses it
  LidarStereoResult::Halves halves;  ///< the LiDAR-stereo split-window check
  std::vector<std::pair<std::string, double>> stage_seconds;  ///< co/joint: time per solve stage
  std::vector<Eigen::Vector2d> brightness;  ///< stereo mode: per keyframe (a, b)
  /// stereo mode with the LiDAR error nuisance: PhotometricResult::lidar_error (NaN: none)
  Vector6d lidar_error_found = Vector6d::Constant(std::nan(""));
  std::string message;
};

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parse(argc, argv, &args)) {
    usage();
    return 2;
  }
  // ------------------------------------------------------------------ data
  std::vector<std::unique_ptr<KittiSequence>> seqs;
  std::vector<std::pair<size_t, size_t>> keyframes;  // (sequence, frame index)
  size_t available = 0;                              // keyframes in all the sequences
  try {
    seqs = openSequences(args.sequences);
    for (size_t si = 0; si < seqs.size(); ++si)
      for (size_t i : seqs[si]->keyframes(0.5)) {
        ++available;
        if (args.windows == "disjoint" || static_cast<int>(keyframes.size()) < args.window)
          keyframes.emplace_back(si, i);
      }
  } catch (const DataError& e) {
    std::cerr << "tescalib_eval: " << e.what() << "\n";
    return 1;
  }
  const StereoRig rig = seqs.front()->rig();
  const size_t window_size =
      args.windows == "disjoint" ? static_cast<size_t>(args.window) : keyframes.size();
  const size_t n_windows = window_size > 0 ? keyframes.size() / window_size : 0;
  if (n_windows == 0) {
    std::cerr << "tescalib_eval: not enough keyframes (" << keyframes.size()
              << ") for one window of " << window_size << "\n";
    return 1;
  }
  keyframes.resize(n_windows * window_size);
  std::cout << "tescalib_eval: mode " << args.mode << ", method " << args.method << ", "
            << keyframes.size() << " of the " << available << " keyframes of " << seqs.size()
            << " sequence(s), "
            << n_windows << " window(s) of " << window_size << ", " << args.trials
            << " trials, init " << args.init_rot_deg << " deg / " << args.init_trans_m
            << " m, seed " << args.seed << "\n";

  // Stereo clouds do not depend on the LiDAR extrinsic: computed once (stereo fixed at the
  // ground truth in lidar_stereo mode). Meshes depend on the view filter of the initial guess and
  // are rebuilt per trial.
  KeyframeSettings kfs;
  // The joint problem's photometric residuals intersect rays with any key point's face along its
  // normal: it needs every face's normal fitted, not only the solvers' sample (held-out starts:
  // 81.5 % with every face fitted, 72.2 % with the sample).
  if (args.mode == "joint") kfs.mesh.sampled_faces = 0;
  // The command line's refinement rounds, over the LiDAR-stereo clouds' default and over the one
  // co / joint match their clouds with (co-calibration's own: one exact round).
  auto withRefineArgs = [&](DisparityRefinementSettings r) {
    if (args.refine_iterations >= 0) r.iterations = args.refine_iterations;
    if (args.refine_smoothed >= 0) r.smoothed_gradient_rounds = args.refine_smoothed;
    return r;
  };
  kfs.stereo.refinement = withRefineArgs(kfs.stereo.refinement);
  const DisparityRefinementSettings co_refinement =
      withRefineArgs(CoCalibrationSettings{}.stereo_cloud.refinement);
  const bool co_clouds = args.mode == "co" || args.mode == "joint";
  const DisparityRefinementSettings& used_refinement =
      co_clouds ? co_refinement : kfs.stereo.refinement;
  if (args.mode != "stereo")  // stereo mode matches no clouds
    std::cout << "  stereo clouds: disparity refinement " << used_refinement.iterations
              << " round(s), " << used_refinement.smoothed_gradient_rounds
              << " of them with the smoothed gradient\n";
  std::vector<Frame> frames;
  std::vector<Keyframe> base;
  double stereo_seconds = 0;
  std::vector<double> kf_stereo_seconds;
  try {
    for (const auto& [si, fi] : keyframes) {
      frames.push_back(seqs[si]->load(fi));
      if (args.deskew > 0 || (args.deskew < 0 && seqs[si]->sweptScans())) {
        // Constant velocity from this scan to the next frame's (or from the previous one's).
        const KittiSequence& seq = *seqs[si];
        if (seq.size() < 2) throw DataError(seq.dir() + ": --deskew needs two frames");
        const size_t j = fi + 1 < seq.size() ? fi + 1 : fi - 1;
        const LidarScan other = seq.loadScan(j);
        const auto t_dk = std::chrono::steady_clock::now();
        const ScanMotion m =
            j > fi ? estimateScanMotion(frames.back().scan, other, seq.stamp(j) - seq.stamp(fi))
                   : estimateScanMotion(other, frames.back().scan, seq.stamp(fi) - seq.stamp(j));
        const double s_dk =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t_dk).count();
        if (m.valid)
          std::printf("  keyframe %zu: de-skewed, %.2f m/s, %.2f deg/s (registered with frame %d, "
                      "RMS %.3f m, %.2f s)\n",
                      frames.size() - 1, m.velocity.norm(), m.angular_velocity.norm() * kDegPerRad,
                      seq.frameId(j), m.rms_m, s_dk);
        else
          std::printf("  keyframe %zu: not de-skewed: %s\n", frames.size() - 1, m.message.c_str());
        deskewScan(&frames.back().scan, m);  // Velodyne: clockwise, 10 Hz, triggered forward
      }
      Keyframe kf;
      kf.stamp = frames.back().stamp;
      kf.scan = frames.back().scan;
      cv::cvtColor(frames.back().left, kf.left_gray, cv::COLOR_BGR2GRAY);
      cv::cvtColor(frames.back().right, kf.right_gray, cv::COLOR_BGR2GRAY);
      base.push_back(std::move(kf));
    }
  } catch (const DataError& e) {
    std::cerr << "tescalib_eval: " << e.what() << "\n";
    return 1;
  }
  if (args.mode == "lidar_stereo") {  // stereo: no cloud needed; co: computed per trial
    // One keyframe per core at a time (as a window is preprocessed in a batch); the time
    // charged to each window is its share of the wall-clock time.
    const auto t_stereo = Clock::now();
    parallelFor(static_cast<int>(base.size()), resolveThreads(kfs.stereo.threads), [&](int k) {
      base[k].stereo = computeStereoCloud(frames[k].left, frames[k].right, rig, rig.T_right_left,
                                          kfs.stereo);
      base[k].T_right_left_used = rig.T_right_left;
    });
    stereo_seconds = std::chrono::duration<double>(Clock::now() - t_stereo).count();
    for (size_t k = 0; k < base.size(); ++k) {
      kf_stereo_seconds.push_back(stereo_seconds / base.size());
      const cv::Mat& disp = base[k].stereo.disparity;
      const double valid = double(cv::countNonZero(disp == disp)) / disp.total();  // NaN != NaN
      std::printf("  keyframe %zu: %zu stereo points, %.0f %% valid disparity, SGBM %.3f s\n", k,
                  base[k].stereo.points.size(), 100 * valid, base[k].stereo.seconds_sgbm);
    }
  }

  LidarStereoSettings solver_settings;
  solver_settings.disparity_sigma = kfs.stereo.disparity_sigma;
  solver_settings.run_coarse = args.stages.find("coarse") != std::string::npos;
  solver_settings.run_fine = args.stages.find("fine") != std::string::npos;
  if (args.cov_cells_x > 0) solver_settings.cov_cells_x = args.cov_cells_x;
  if (args.stereo_yaw >= 0) solver_settings.estimate_stereo_yaw = args.stereo_yaw > 0;
  if (args.stereo_scale >= 0) solver_settings.estimate_stereo_scale = args.stereo_scale > 0;
  if (args.check_halves >= 0) solver_settings.check_window_halves = args.check_halves > 0;
  if (args.measure_offset >= 0) solver_settings.measure_disparity_offset = args.measure_offset > 0;
  if (args.coarse_nuisances >= 0)
    solver_settings.coarse_estimates_stereo_nuisances = args.coarse_nuisances > 0;
  if (!args.coarse_gates.empty()) solver_settings.coarse_gates = args.coarse_gates;
  if (args.search_deg >= 0) solver_settings.search_step_deg = args.search_deg;
  if (args.cov_cells_y > 0) solver_settings.cov_cells_y = args.cov_cells_y;
  if (args.cov_model_scale >= 0) {
    for (double& v : solver_settings.model_sigma_rot_deg) v *= args.cov_model_scale;
    for (double& v : solver_settings.model_sigma_trans_m) v *= args.cov_model_scale;
    solver_settings.model_sigma_disparity_px *= args.cov_model_scale;
    solver_settings.model_sigma_range_m *= args.cov_model_scale;
  }
  std::vector<Trial> trials;
  std::cout << " trial  conv  init(deg,m)    err rot [x y z] deg          err trans [x y z] cm"
               "        sigma(deg,cm)   iters  prep(s) solve(s)\n";
  for (int t = args.first_trial; t < args.first_trial + args.trials; ++t) {
    Trial tr;
    tr.seed = args.seed * 1000003ULL + t;
    std::mt19937_64 rng(tr.seed);
    const bool stereo_mode = args.mode == "stereo";
    const bool co_mode = args.mode == "co" || args.mode == "joint";
    const Vector6d main_delta =
        randomPerturbation(args.init_rot_deg / kDegPerRad, args.init_trans_m, rng);
    Eigen::Isometry3d T_init = rig.T_cam_lidar;
    if (co_mode) {
      tr.lidar.init = main_delta;
      tr.stereo.init =
          randomPerturbation(args.init_stereo_rot_deg / kDegPerRad, args.init_stereo_trans_m, rng);
    } else if (stereo_mode) {
      tr.stereo.init = main_delta;
      tr.lidar.init = randomPerturbation(args.lidar_rot_deg / kDegPerRad, args.lidar_trans_m, rng);
    } else {
      tr.lidar.init = main_delta;
    }
    T_init = perturb(rig.T_cam_lidar, tr.lidar.init);
    // The extrinsic the mode does not estimate is given: its error is where it was put.
    if (stereo_mode) tr.lidar.estimated = false, tr.lidar.err = tr.lidar.init;
    if (!stereo_mode && !co_mode) tr.stereo.estimated = false;
    // Per-trial meshes, view-filtered with the initial guess (never the ground truth).
    const auto t_pre = Clock::now();
    const LidarMeshSettings ms = meshSettingsForView(rig, T_init, kfs);
    tr.window_index = static_cast<int>(t % n_windows);
    const size_t first = tr.window_index * window_size;
    std::vector<Keyframe*> mwin;
    double window_stereo_seconds = 0;
    for (size_t k = first; k < first + window_size; ++k) {
      mwin.push_back(&base[k]);
      if (k < kf_stereo_seconds.size()) window_stereo_seconds += kf_stereo_seconds[k];
    }
    std::vector<const Keyframe*> window;
    LidarMeshSettings ms_one = ms;
    ms_one.threads = 1;  // one keyframe per core instead
    parallelFor(static_cast<int>(mwin.size()), resolveThreads(ms.threads),
                [&](int k) { mwin[k]->mesh = buildLidarMesh(mwin[k]->scan, ms_one); });
    for (Keyframe* kfp : mwin) {
      if (t == 0)
        std::printf("  keyframe %zu: %zu LiDAR faces in view\n", window.size(),
                    kfp->mesh.faces.size());
      window.push_back(kfp);
    }
    tr.preprocess =
        std::chrono::duration<double>(Clock::now() - t_pre).count() + window_stereo_seconds;
    const auto t_solve = Clock::now();
    Eigen::Isometry3d T_est = T_init;
    if (co_mode) {
      CoCalibrationSettings cs;
      cs.stereo_cloud.refinement = co_refinement;
      cs.lidar.cov_cells_x = solver_settings.cov_cells_x;
      cs.lidar.cov_cells_y = solver_settings.cov_cells_y;
      cs.lidar.model_sigma_rot_deg = solver_settings.model_sigma_rot_deg;
      cs.lidar.model_sigma_trans_m = solver_settings.model_sigma_trans_m;
      cs.lidar.model_sigma_disparity_px = solver_settings.model_sigma_disparity_px;
      cs.lidar.model_sigma_range_m = solver_settings.model_sigma_range_m;
      cs.lidar.check_window_halves = solver_settings.check_window_halves;
      cs.lidar.coarse_estimates_stereo_nuisances =
          solver_settings.coarse_estimates_stereo_nuisances;
      cs.lidar.measure_disparity_offset = solver_settings.measure_disparity_offset;
      if (args.smooth_keypoints_px >= 0)
        cs.stereo.smooth_depth_radius_px = args.smooth_keypoints_px;
      if (args.depth_prior >= 0) cs.free_depth_prior_sigma = args.depth_prior;
      if (args.free_depth_rounds >= 0) cs.free_depth_rounds = args.free_depth_rounds;
      if (args.rematch_deg != 0) {
        cs.rematch_deg = args.rematch_deg;
        cs.rematch_direction_deg = 5 * args.rematch_deg;
      }
      if (args.stereo_yaw >= 0) cs.lidar_estimates_stereo_yaw = args.stereo_yaw > 0;
      if (args.co_model_scale >= 0) {
        for (auto* v : {&cs.model_sigma_lidar_rot_deg, &cs.model_sigma_lidar_trans_m,
                        &cs.model_sigma_stereo_rot_deg, &cs.model_sigma_stereo_trans_m})
          for (double& x : *v) x *= args.co_model_scale;
      }
      const Eigen::Isometry3d T_rl_init = perturb(rig.T_right_left, tr.stereo.init);
      CoCalibrationResult r;
      if (args.mode == "joint") {
        JointCalibrationSettings jset;
        jset.co = cs;
        r = jointCalibrate(mwin, rig, T_init, T_rl_init, jset);
      } else {
        r = coCalibrate(mwin, rig, T_init, T_rl_init, cs);
      }
      tr.converged = r.converged;
      tr.iterations = r.rounds;
      tr.rematches = r.rematches;
      tr.yaw_handovers = r.yaw_handovers;
      tr.stereo_scale = r.lidar.stereo_scale;
      tr.stereo_scale_sigma = std::sqrt(r.lidar.stereo_scale_variance);
      tr.halves = r.lidar.halves;
      tr.stage_seconds = {{"photometric", r.seconds_photometric},
                          {"stereo_cloud", r.seconds_stereo_cloud},
                          {"lidar_stereo", r.seconds_lidar}};
      tr.lidar.cov = r.lidar.covariance;
      tr.lidar.cov_stat = r.lidar.covariance_statistical;
      tr.lidar.bias = r.lidar.bias_sensitivity;
      tr.stereo.cov = r.stereo.covariance;
      T_est = r.lidar.T_cam_lidar;
      tr.stereo.err = poseError(r.stereo.T_right_left, rig.T_right_left);
      tr.message = r.message;
      tr.brightness = r.stereo.brightness;
    } else if (stereo_mode) {
      PhotometricSettings ps;
      if (args.smooth_keypoints_px >= 0) ps.smooth_depth_radius_px = args.smooth_keypoints_px;
      if (args.depth_prior >= 0) ps.depth_prior_sigma = args.depth_prior;
      // With free depth the given LiDAR extrinsic's uncertainty is also the prior of its error as
      // a nuisance of the key points' depths.
      ps.lidar_error_sigma_rot_deg = args.lidar_sigma_deg;
      ps.lidar_error_sigma_trans_m = args.lidar_sigma_m;
      PhotometricResult r =
          solvePhotometric(window, rig, T_init, perturb(rig.T_right_left, tr.stereo.init), ps);
      if (args.lidar_sigma_deg > 0 || args.lidar_sigma_m > 0) {
        Matrix6d P = Matrix6d::Zero();
        addAxisVariances(&P, {args.lidar_sigma_deg, args.lidar_sigma_deg, args.lidar_sigma_deg},
                         {args.lidar_sigma_m, args.lidar_sigma_m, args.lidar_sigma_m});
        addLidarUncertainty(&r, P);
      }
      tr.converged = r.converged;
      tr.iterations = r.iterations;
      tr.stereo.cov = r.covariance;
      tr.stereo.err = poseError(r.T_right_left, rig.T_right_left);
      if (std::getenv("TESCALIB_DEBUG"))
        std::fprintf(stderr, "photo-consistency ratio %.3f over %d key points\n",
                     r.consistency_ratio, r.inliers);
      tr.message = r.message;
      tr.brightness = r.brightness;
      if (!r.lidar_error.isZero()) tr.lidar_error_found = r.lidar_error;
    } else if (args.method == "tescalib") {
      const LidarStereoResult r = solveLidarStereoSearch(window, T_init, solver_settings);
      T_est = r.T_cam_lidar;
      tr.converged = r.converged;
      tr.iterations = r.iterations;
      tr.lidar.cov = r.covariance;
      tr.lidar.cov_stat = r.covariance_statistical;
      tr.lidar.bias = r.bias_sensitivity;
      tr.lidar_cov_model = r.covariance_model;
      tr.halves = r.halves;
      tr.message = r.message;
      if (solver_settings.estimate_stereo_scale) {
        tr.stereo_scale = r.stereo_scale;
        tr.stereo_scale_sigma = std::sqrt(r.stereo_scale_variance);
      }
      if (solver_settings.estimate_stereo_yaw) tr.stereo_yaw_deg = r.stereo_yaw_rad * kDegPerRad;
      if (solver_settings.measure_disparity_offset && !solver_settings.estimate_stereo_yaw) {
        tr.disparity_offset_px = r.disparity_offset_px;
        tr.disparity_offset_sigma_px = r.disparity_offset_sigma_px;
        tr.disparity_offset_used = disparityOffsetWidensBias(r, solver_settings);
      }
    } else {
      const GicpBaselineResult r = solveGicpBaseline(window, T_init);
      T_est = r.T_cam_lidar;
      tr.converged = r.converged;
      tr.lidar.cov = Matrix6d::Constant(std::nan(""));
    }
    tr.solve = std::chrono::duration<double>(Clock::now() - t_solve).count();
    ExtrinsicOutcome& est = stereo_mode ? tr.stereo : tr.lidar;
    if (!stereo_mode) tr.lidar.err = poseError(T_est, rig.T_cam_lidar);
    if (args.method == "tescalib") {
      Eigen::LDLT<Matrix6d> ldlt(est.cov);
      tr.nees = est.err.dot(ldlt.solve(est.err));
      if (tr.lidar_cov_model.allFinite())
        tr.nees_model = est.err.dot(tr.lidar_cov_model.ldlt().solve(est.err));
      if (co_mode) {  // mean of both extrinsics' 6-DoF NEES
        Eigen::LDLT<Matrix6d> ldlt_s(tr.stereo.cov);
        tr.nees = 0.5 * (tr.nees + tr.stereo.err.dot(ldlt_s.solve(tr.stereo.err)));
      }
    }
    const Vector6d& e = est.err;
    std::printf(
        " %4d   %s   %4.2f/%4.2f  [%7.4f %7.4f %7.4f]  [%7.3f %7.3f %7.3f]  %6.3f/%6.2f  %4d  "
        "%6.2f  %6.2f %s\n",
        t, tr.converged ? "yes" : " no", est.init.head<3>().norm() * kDegPerRad,
        est.init.tail<3>().norm(), e[0] * kDegPerRad, e[1] * kDegPerRad, e[2] * kDegPerRad,
        e[3] * 100, e[4] * 100, e[5] * 100,
        std::sqrt(est.cov.topLeftCorner<3, 3>().trace() / 3) * kDegPerRad,
        std::sqrt(est.cov.bottomRightCorner<3, 3>().trace() / 3) * 100, tr.iterations,
        tr.preprocess, tr.solve,
        (est.success() && (!co_mode || tr.stereo.success())) ? ""
                                                             : (" FAIL " + tr.message).c_str());
    if (co_mode) {
      const Vector6d& es = tr.stereo.err;
      std::printf(
          "        stereo  %4.2f/%4.2f  [%7.4f %7.4f %7.4f]  [%7.3f %7.3f %7.3f]  %6.3f/%6.2f\n",
          tr.stereo.init.head<3>().norm() * kDegPerRad, tr.stereo.init.tail<3>().norm(),
          es[0] * kDegPerRad, es[1] * kDegPerRad, es[2] * kDegPerRad, es[3] * 100, es[4] * 100,
          es[5] * 100, std::sqrt(tr.stereo.cov.topLeftCorner<3, 3>().trace() / 3) * kDegPerRad,
          std::sqrt(tr.stereo.cov.bottomRightCorner<3, 3>().trace() / 3) * 100);
    }
    std::fflush(stdout);
    trials.push_back(tr);
  }

  // ------------------------------------------------------------------ summary
  const bool stereo_mode = args.mode == "stereo";
  const bool co_mode = args.mode == "co" || args.mode == "joint";
  // The extrinsics the mode estimates; a trial succeeds when all of them do.
  std::vector<std::pair<std::string, const ExtrinsicOutcome Trial::*>> estimated;
  if (!stereo_mode) estimated.emplace_back("lidar", &Trial::lidar);
  if (stereo_mode || co_mode) estimated.emplace_back("stereo", &Trial::stereo);
  auto trialSuccess = [&](const Trial& tr) {
    bool ok = true;
    for (const auto& e : estimated) ok = ok && (tr.*(e.second)).success();
    return ok;
  };
  std::vector<double> pre, sol, nees, nees_model, nees_converged;
  int ok_all = 0;
  for (const auto& tr : trials) {
    pre.push_back(tr.preprocess);
    sol.push_back(tr.solve);
    if (std::isfinite(tr.nees)) nees.push_back(tr.nees);
    if (std::isfinite(tr.nees) && tr.converged) nees_converged.push_back(tr.nees);
    if (std::isfinite(tr.nees_model)) nees_model.push_back(tr.nees_model);
    ok_all += trialSuccess(tr);
  }
  double mean_nees_model = std::nan("");
  if (!nees_model.empty()) {
    mean_nees_model = 0;
    for (double v : nees_model) mean_nees_model += v / nees_model.size();
  }
  auto mean = [](const std::vector<double>& v) {
    double m = std::nan("");
    if (!v.empty()) m = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    return m;
  };
  const double mean_nees = mean(nees);
  // Over the trials the estimator declared converged: the estimates an online node publishes.
  const double mean_nees_converged = mean(nees_converged);
  std::printf("\nsummary (%s, %s, %zu window(s) of %zu, %zu trials)\n", args.mode.c_str(),
              args.method.c_str(), n_windows, window_size, trials.size());
  std::printf("  success rate (< 0.2 deg and < 3 cm%s): %.1f %%\n",
              estimated.size() > 1 ? ", both extrinsics" : "", 100.0 * ok_all / trials.size());
  std::ostringstream summary_json;
  for (const auto& [name, member] : estimated) {
    double med_rot[3], med_trans[3];
    // What the windows constrain: the median statistical sigma per axis (no model error).
    double stat_rot[3], stat_trans[3];
    std::vector<double> rn, tn;
    int ok = 0;
    for (int i = 0; i < 3; ++i) {
      std::vector<double> r, tt, sr, st;
      for (const auto& tr : trials) {
        r.push_back(std::fabs((tr.*member).err[i]) * kDegPerRad);
        tt.push_back(std::fabs((tr.*member).err[3 + i]));
        const Matrix6d& c = (tr.*member).cov_stat;
        if (!c.allFinite()) continue;
        sr.push_back(std::sqrt(c(i, i)) * kDegPerRad);
        st.push_back(std::sqrt(c(3 + i, 3 + i)));
      }
      med_rot[i] = median(r);
      med_trans[i] = median(tt);
      stat_rot[i] = median(sr);
      stat_trans[i] = median(st);
    }
    for (const auto& tr : trials) {
      rn.push_back((tr.*member).err.head<3>().norm() * kDegPerRad);
      tn.push_back((tr.*member).err.tail<3>().norm());
      ok += (tr.*member).success();
    }
    const double success = double(ok) / trials.size();
    std::printf("  %s: success %.1f %%\n", name.c_str(), 100.0 * success);
    std::printf("    median |err| rot  [x y z] deg: %.4f %.4f %.4f   (median norm %.4f deg)\n",
                med_rot[0], med_rot[1], med_rot[2], median(rn));
    std::printf("    median |err| trans [x y z] cm: %.3f %.3f %.3f   (median norm %.3f cm)\n",
                med_trans[0] * 100, med_trans[1] * 100, med_trans[2] * 100, median(tn) * 100);
    if (std::isfinite(stat_rot[0]))
      std::printf(
          "    median statistical sigma (what the window constrains) rot [x y z] deg: %.4f %.4f "
          "%.4f, trans cm: %.3f %.3f %.3f\n",
          stat_rot[0], stat_rot[1], stat_rot[2], stat_trans[0] * 100, stat_trans[1] * 100,
          stat_trans[2] * 100);
    summary_json << "\"" << name << "\": {\"median_abs_rot_err_deg\": " << jsonArray(med_rot, 3)
                 << ", \"median_abs_trans_err_m\": " << jsonArray(med_trans, 3)
                 << ", \"success_rate\": " << success;
    if (std::isfinite(stat_rot[0]))
      summary_json << ", \"median_sigma_statistical_rot_deg\": " << jsonArray(stat_rot, 3)
                   << ", \"median_sigma_statistical_trans_m\": " << jsonArray(stat_trans, 3);
    summary_json << std::setprecision(10) << ", \"median_rot_err_norm_deg\": " << median(rn)
                 << ", \"median_trans_err_norm_m\": " << median(tn) << "}, ";
  }
  // The extrinsic the mode does not estimate: named, so that both keys are always there.
  for (const char* name : {"lidar", "stereo"})
    if (std::none_of(estimated.begin(), estimated.end(),
                     [&](const auto& e) { return e.first == name; }))
      summary_json << "\"" << name << "\": {\"estimated\": false}, ";
  std::printf(
      "  time per window: preprocess %.2f s (stereo %.2f s, %zu keyframes), solve median %.2f s\n",
      median(pre), stereo_seconds / n_windows, window_size, median(sol));
  if (std::isfinite(mean_nees)) std::printf("  mean NEES (6 DoF, ideal 6): %.2f\n", mean_nees);
  if (std::isfinite(mean_nees_converged))
    std::printf("  mean NEES of the %zu converged trials: %.2f\n", nees_converged.size(),
                mean_nees_converged);
  if (std::isfinite(mean_nees_model))
    std::printf("  mean NEES with the paper's covariance alone (eq. residual_uncertainty): %.2f\n",
                mean_nees_model);
  {
    std::vector<double> chi2;
    int beyond = 0;
    for (const auto& tr : trials)
      if (tr.halves.tested) {
        chi2.push_back(tr.halves.chi2);
        beyond += tr.halves.covariance_scale > 1.0;
      }
    if (!chi2.empty())
      std::printf("  split-window check: %zu of %zu trials tested, median chi2 %.1f (6 DoF), %d "
                  "beyond the limit (covariance scaled)\n",
                  chi2.size(), trials.size(), median(chi2), beyond);
  }

  {
    std::vector<double> offsets;
    int beyond = 0;
    for (const auto& tr : trials)
      if (std::isfinite(tr.disparity_offset_px)) {
        offsets.push_back(tr.disparity_offset_px);
        beyond += tr.disparity_offset_used;
      }
    if (!offsets.empty())
      std::printf(
          "  disparity offset the residuals show: median %+.3f px, %d of %zu trials determine "
          "one beyond the model's %.3f px (their bias term uses it)\n",
          median(offsets), beyond, offsets.size(), solver_settings.model_sigma_disparity_px);
  }

  {
    // The LiDAR error nuisance: the error applied (--lidar-rot-deg / --lidar-trans-m) and what is
    // left of it after the correction the left-right solve found (perturb(T, found)).
    std::vector<double> rot_applied, trans_applied, rot_left, trans_left;
    for (const auto& tr : trials) {
      if (!std::isfinite(tr.lidar_error_found[0])) continue;
      const Vector6d left = poseError(
          perturb(perturb(Eigen::Isometry3d::Identity(), tr.lidar.init), tr.lidar_error_found),
          Eigen::Isometry3d::Identity());
      rot_applied.push_back(tr.lidar.init.head<3>().norm() * kDegPerRad);
      trans_applied.push_back(100 * tr.lidar.init.tail<3>().norm());
      rot_left.push_back(left.head<3>().norm() * kDegPerRad);
      trans_left.push_back(100 * left.tail<3>().norm());
    }
    if (!rot_left.empty())
      std::printf(
          "  LiDAR error nuisance: applied %.3f deg / %.2f cm, left after its estimate %.3f deg / "
          "%.2f cm (medians of %zu trials)\n",
          median(rot_applied), median(trans_applied), median(rot_left), median(trans_left),
          rot_left.size());
  }

  if (!args.json.empty()) {
    std::ofstream js(args.json);
    if (!js) {
      std::cerr << "tescalib_eval: cannot write " << args.json << "\n";
      return 1;
    }
    js << std::setprecision(10) << "{\"mode\": \"" << args.mode << "\", \"method\": \""
       << args.method << "\", \"window\": " << window_size << ", \"windows\": " << n_windows
       << ", \"refinement\": {\"iterations\": " << used_refinement.iterations
       << ", \"smoothed_rounds\": " << used_refinement.smoothed_gradient_rounds
       << "}, \"trials\": [\n";
    for (size_t i = 0; i < trials.size(); ++i) {
      const auto& tr = trials[i];
      js << "  {\"seed\": " << tr.seed << ", \"window_index\": " << tr.window_index
         << ", \"converged\": " << (tr.converged ? "true" : "false")
         << ", \"success\": " << (trialSuccess(tr) ? "true" : "false")
         << ", \"lidar\": " << tr.lidar.json() << ", \"stereo\": " << tr.stereo.json();
      if (stereo_mode || co_mode) {
        js << ", \"brightness\": [";
        for (size_t b = 0; b < tr.brightness.size(); ++b)
          js << (b ? ", " : "") << "[" << tr.brightness[b].x() << ", " << tr.brightness[b].y()
             << "]";
        js << "]";
      }
      js << ", \"nees\": " << jsonNumber(tr.nees)
         << ", \"nees_model\": " << jsonNumber(tr.nees_model)
         << ", \"iterations\": " << tr.iterations;
      if (tr.rematches >= 0) js << ", \"rematches\": " << tr.rematches;
      if (tr.yaw_handovers >= 0) js << ", \"yaw_handovers\": " << tr.yaw_handovers;
      if (std::isfinite(tr.stereo_scale))
        js << ", \"stereo_scale\": " << tr.stereo_scale
           << ", \"stereo_scale_sigma\": " << tr.stereo_scale_sigma;
      if (std::isfinite(tr.stereo_yaw_deg)) js << ", \"stereo_yaw_deg\": " << tr.stereo_yaw_deg;
      if (std::isfinite(tr.disparity_offset_px))
        js << ", \"disparity_offset_px\": " << tr.disparity_offset_px
           << ", \"disparity_offset_sigma_px\": " << tr.disparity_offset_sigma_px
           << ", \"disparity_offset_used\": " << (tr.disparity_offset_used ? "true" : "false");
      if (std::isfinite(tr.lidar_error_found[0])) {
        js << ", \"lidar_error_found\": [";
        for (int i = 0; i < 6; ++i)
          js << (i ? ", " : "")
             << (i < 3 ? tr.lidar_error_found[i] * kDegPerRad : tr.lidar_error_found[i]);
        js << "]";
      }
      if (tr.halves.tested)
        js << ", \"halves\": {\"chi2\": " << tr.halves.chi2
           << ", \"covariance_scale\": " << tr.halves.covariance_scale
           << ", \"seconds\": " << tr.halves.seconds << "}";
      js << ", \"seconds\": {\"preprocess\": " << tr.preprocess << ", \"solve\": " << tr.solve
         << ", \"total\": " << tr.preprocess + tr.solve;
      for (const auto& [stage, sec] : tr.stage_seconds) js << ", \"" << stage << "\": " << sec;
      js << "}}" << (i + 1 < trials.size() ? ",\n" : "\n");
    }
    js << "], \"summary\": {" << summary_json.str()
       << "\"success_rate\": " << double(ok_all) / trials.size()
       << ", \"mean_nees\": " << jsonNumber(mean_nees)
       << ", \"mean_nees_converged\": " << jsonNumber(mean_nees_converged)
       << ", \"mean_nees_model\": " << jsonNumber(mean_nees_model)
       << ", \"seconds\": {\"preprocess\": " << median(pre) << ", \"solve\": " << median(sol)
       << "}}}\n";
    std::cout << "wrote " << args.json << "\n";
  }
  return 0;
}
