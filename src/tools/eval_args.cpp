#include "eval_args.h"

#include <cstdint>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib::eval {

namespace {

using cli::add;
using cli::to;

const char* const kUsage =
    "usage: rosrun tescalib tescalib_eval --sequences DIR[,DIR...] [OPTIONS]";
const char* const kDescription =
    "Runs the calibration on KITTI-layout sequences from perturbed initial guesses and measures "
    "it against the ground truth (doc/evaluation.md has the conventions and the JSON).";
const char* const kFooter =
    "Modes: lidar_stereo (T_cam_lidar estimated, stereo at ground truth), stereo (T_right_left "
    "estimated from the --init sizes, LiDAR at ground truth or perturbed by --lidar-*), co (both: "
    "LiDAR from the --init sizes, stereo from the --init-stereo sizes), joint (as co, one "
    "least-squares "
    "problem over both extrinsics).\n"
    "Sequences are KITTI folders (odometry or raw layout) sharing one calibration (real, or "
    "written by tescalib_simulate). Keyframes are frames >= 0.5 s apart; the window holds the "
    "first W.\n"
    "A trial perturbs the ground truth by exactly R deg about a random axis and T m in a random "
    "direction and succeeds when the error is below 0.2 deg and 3 cm.\n"
    "--help-expert also lists the study options of the solvers (doc/evaluation.md).";

/// The run: data, mode, trials, initial guesses and output.
void addRunOptions(CLI::App* app, Args* a) {
  const char* g = "Run";
  add(app, "--sequences", "DIR[,DIR...]",
      to(&a->sequences, [](const std::string& v) { return cli::splitList(v); }),
      "KITTI folders (odometry or raw layout) of one rig; required")
      ->group(g);
  add(app, "--mode", "MODE", to(&a->mode, cli::text),
      "lidar_stereo, stereo, co or joint (default lidar_stereo)")
      ->group(g);
  add(app, "--method", "METHOD", to(&a->method, cli::text),
      "tescalib, pcl_gicp (a baseline of lidar_stereo) or features (a baseline of stereo); "
      "default tescalib")
      ->group(g);
  add(app, "--trials", "N", to(&a->trials, cli::toInt), "trials (default 10)")->group(g);
  add(app, "--first-trial", "K", to(&a->first_trial, cli::atLeast(0)),
      "runs trials K .. K + N - 1 (default 0)")
      ->group(g);
  add(app, "--seed", "S", to(&a->seed, cli::toSeed),
      "trial t's seed is S * 1000003 + t (default 1)")
      ->group(g);
  add(app, "--window", "W", to(&a->window, cli::toInt), "keyframes per window (default 20)")
      ->group(g);
  add(app, "--windows", "first|disjoint", to(&a->windows, cli::text),
      "first: the first W keyframes (default); disjoint: all keyframes split into consecutive "
      "windows of W, trial t uses window t mod (number of windows): independent windows, so mean "
      "NEES means something")
      ->group(g);
  add(app, "--init-rot-deg", "R", to(&a->init_rot_deg, cli::toNonNegative),
      "the initial guess' rotation error (default 3)")
      ->group(g);
  add(app, "--init-trans-m", "T", to(&a->init_trans_m, cli::toNonNegative),
      "the initial guess' translation error (default 0.3)")
      ->group(g);
  add(app, "--init-stereo-rot-deg", "R", to(&a->init_stereo_rot_deg, cli::toNonNegative),
      "co, joint: the stereo pair's rotation error (default 1)")
      ->group(g);
  add(app, "--init-stereo-trans-m", "T", to(&a->init_stereo_trans_m, cli::toNonNegative),
      "co, joint: the stereo pair's translation error (default 0.1)")
      ->group(g);
  add(app, "--json", "FILE", to(&a->json, cli::text), "writes the results as JSON")->group(g);
  add(app, "--score-estimates", "FILE", to(&a->score_estimates, cli::text),
      "instead of trials: scores tescalib_calibrate --json FILE's estimates of the drive in "
      "--sequences against the truth of each one's moment (calib.txt, calib_after_step.txt): "
      "the monitor's delays, the recalibrated estimate, false alarms (doc/online.md)")
      ->group(g);
}

/// The keyframes: de-skewing and sparser scans.
void addDataOptions(CLI::App* app, Args* a) {
  const char* g = "Keyframes";
  add(app, "--deskew", "0|1", to(&a->deskew, cli::toSwitch),
      "motion-compensate each keyframe's scan to the camera trigger with the velocity registered "
      "against the sequence's next frame (default: on for KITTI raw recordings and "
      "tescalib_simulate --lidar-sweep 1 output; off for KITTI odometry sequences, which KITTI "
      "compensated, and the generator's default output)")
      ->group(g);
  add(app, "--keep-rings", "N", to(&a->keep_rings, cli::atLeast(1)),
      "keep every Nth laser ring of each scan (a sparser LiDAR from the same drive: 64 rings with "
      "N = 2 are 32, with N = 4 16 rings about 1.7 deg apart)")
      ->group(g);
}

/// --cov-cells XxY: both at least 1.
void setCovCells(const std::string& v, Args* a) {
  const auto x = v.find('x');
  if (x == std::string::npos) throw std::invalid_argument(v);
  a->cov_cells_x = cli::toInt(v.substr(0, x));
  a->cov_cells_y = cli::toInt(v.substr(x + 1));
  if (a->cov_cells_x < 1 || a->cov_cells_y < 1) throw std::invalid_argument(v);
}

/// --coarse-gates M,M,...: positive, at least one.
std::vector<double> coarseGates(const std::string& v) {
  std::vector<double> gates;
  for (const auto& g : cli::splitList(v)) {
    gates.push_back(cli::toDouble(g));
    if (!(gates.back() > 0)) throw std::invalid_argument(v);
  }
  if (gates.empty()) throw std::invalid_argument(v);
  return gates;
}

/// --lidar-sigma DEG,M: both >= 0.
void setLidarSigma(const std::string& v, Args* a) {
  const auto parts = cli::splitList(v);
  if (parts.size() != 2) throw std::invalid_argument(v);
  a->lidar_sigma_deg = cli::toNonNegative(parts[0]);
  a->lidar_sigma_m = cli::toNonNegative(parts[1]);
}

/// Stereo mode's given LiDAR extrinsic: how far off it is and how uncertain it is said to be.
void addStereoModeOptions(CLI::App* app, Args* a) {
  const char* g = "Stereo mode";
  add(app, "--lidar-rot-deg", "R", to(&a->lidar_rot_deg, cli::toNonNegative),
      "the given LiDAR extrinsic's rotation error (default 0)")
      ->group(g);
  add(app, "--lidar-trans-m", "T", to(&a->lidar_trans_m, cli::toNonNegative),
      "the given LiDAR extrinsic's translation error (default 0)")
      ->group(g);
  add(
      app, "--lidar-sigma", "DEG,M", [a](const std::string& v) { setLidarSigma(v, a); },
      "the given LiDAR extrinsic's 1-sigma per axis; the left-right covariance adds what it does "
      "to the key points' depth (default 0: exact); with --depth-prior (an expert option) its "
      "error is also a nuisance of the key points' depths, with this prior")
      ->group(g);
}

/// Study options of the keyframes: the meshes' sample and the stereo clouds' refinement.
void addKeyframeStudyOptions(CLI::App* app, Args* a, const cli::ExpertOptions& expert) {
  const std::string g = expert.group("Keyframes");
  add(app, "--consistent-sample", "0|1", to(&a->consistent_sample, cli::toSwitch),
      "draw each mesh's faces by their place in the range image (default 0: evenly strided over "
      "the faces in view, which moves with the initial guess' view cone)")
      ->group(g);
  add(app, "--refine-iterations", "N", to(&a->refine_iterations, cli::atLeast(0)),
      "rounds of the stereo clouds' sub-pixel disparity refinement (0 keeps SGBM's disparities; "
      "default 2 in lidar_stereo mode, 1 for the clouds co and joint match again)")
      ->group(g);
  add(app, "--sgbm-paths", "3|5|8", to(&a->sgbm_paths, cli::toSgbmPaths),
      "SGBM's aggregation paths of every stereo cloud (default 3, as the node's "
      "stereo/sgbm_paths; 8 also aggregates from below)")
      ->group(g);
  add(app, "--sgbm-both-ways", "0|1", to(&a->sgbm_both_ways, cli::toSwitch),
      "match every pair upright and upside down and keep the mean (default 1, as the node's "
      "stereo/sgbm_both_ways)")
      ->group(g);
  add(app, "--rectified-vertical-blur", "PX", to(&a->rectified_vertical_blur, cli::toNonNegative),
      "the keyframes' clouds: a low-pass along the columns (Gaussian sigma, px) of both images "
      "of a re-rectified pair before matching (default 0.8, as the node's "
      "stereo/rectified_vertical_blur_px; 0: off; co's re-matched clouds: off)")
      ->group(g);
  add(app, "--refine-smoothed-rounds", "N", to(&a->refine_smoothed, cli::atLeast(0)),
      "of those rounds, the first N follow a smoothed image gradient (default 1 in lidar_stereo "
      "mode, 0 in co and joint)")
      ->group(g);
}

/// Study options of the LiDAR-stereo solver.
void addLidarStereoOptions(CLI::App* app, Args* a, const cli::ExpertOptions& expert) {
  const std::string g = expert.group("LiDAR-stereo solver");
  add(app, "--stages", "coarse,fine", to(&a->stages, cli::text),
      "lidar_stereo mode: the stages to run (coarse, fine or both)")
      ->group(g);
  add(app, "--search-deg", "D",
      to(&a->search_deg,
         [](const std::string& v) {
           const double d = cli::toNonNegative(v);
           if (d > LidarStereoSettings::kMaxSearchStepDeg) throw std::invalid_argument(v);
           return d;
         }),
      "lidar_stereo mode (co: the LiDAR-first fallback's solve): a solve that does not converge "
      "is tried again from the start turned by +-D deg about the camera's x and y axes, 8 more "
      "starts (default 10; 0: off)")
      ->group(g);
  add(app, "--coarse-gates", "M,M,...", to(&a->coarse_gates, coarseGates),
      "the coarse stage's association gates (6-D distances), one stage each (default 2,1,0.5; co "
      "and joint: their LiDAR-stereo solves)")
      ->group(g);
  add(app, "--coarse-nuisances", "0|1", to(&a->coarse_nuisances, cli::toSwitch),
      "the coarse stage also estimates the clouds' scale and yaw where they are estimated (co; "
      "default 0: only the fine stage does)")
      ->group(g);
  add(app, "--stereo-yaw", "0|1", to(&a->stereo_yaw, cli::toSwitch),
      "the solve also estimates the right camera's yaw relative to the clouds' rectification (a "
      "disparity offset; co: the node's co_calibration/lidar_estimates_stereo_yaw)")
      ->group(g);
  add(app, "--stereo-scale", "0|1", to(&a->stereo_scale, cli::toSwitch),
      "lidar_stereo mode: the solve also estimates a scale of the stereo clouds (default 1; "
      "always on in co; 0: the clouds' baseline is exact)")
      ->group(g);
  add(app, "--check-halves", "0|1", to(&a->check_halves, cli::toSwitch),
      "after a converged solve, solve each half of the window again; disagreeing halves widen the "
      "covariance (default 1)")
      ->group(g);
  add(
      app, "--halves-start", "recheck|estimate|initial",
      [a](const std::string& v) {
        HalvesStart start;
        if (!halvesStartFromName(v, &start)) throw std::invalid_argument(v);
        a->halves_start = int(start);
      },
      "where the window's halves start: its estimate and, when they disagree or both leave it, "
      "again from the initial guess, refusing the estimate when a half then settles elsewhere "
      "(recheck, the default); its estimate only (estimate); the initial guess (initial)")
      ->group(g);
  add(app, "--measure-offset", "0|1", to(&a->measure_offset, cli::toSwitch),
      "measure the disparity offset the residuals show and widen the covariance's bias term with "
      "it (default 1)")
      ->group(g);
  add(
      app, "--cov-cells", "XxY", [a](const std::string& v) { setCovCells(v, a); },
      "image cells per keyframe of the covariance's sandwich estimator (default 8x3)")
      ->group(g);
  add(app, "--ring-clusters", "N", to(&a->ring_clusters, cli::atLeast(0)),
      "the covariance's sandwich also clusters the residuals by groups of N LiDAR rings (default "
      "2; 0: by image cell alone)")
      ->group(g);
  add(app, "--fine-stereo-normal", "H", to(&a->fine_stereo_normal_px, cli::atLeast(0)),
      "H > 0: the fine residual's derivative follows the stereo surface, its normal fitted over "
      "(2H+1)^2 pixels (6 is the size studied; 0: the LiDAR face's normal alone). Default: 0 for "
      "the LiDAR-stereo solves, 6 for co and joint (co_calibration/fine_stereo_normal_px)")
      ->group(g);
  add(app, "--align-rows", "0|1", to(&a->align_rows, cli::toSwitch),
      "lidar_stereo mode: measure how far the right image's rows lie from where the calibration "
      "puts them on keyframe 0 and match every pair again re-rectified for the right camera's "
      "pitch and roll that explain it (default 1, as the node's stereo/align_rows)")
      ->group(g);
  add(app, "--ring-range-sigma", "M", to(&a->ring_range_sigma, cli::toNonNegative),
      "the fine stage estimates a range offset per LiDAR ring with this prior sigma (m; default 0: "
      "not estimated; 0.1 for a LiDAR whose lasers disagree)")
      ->group(g);
  add(app, "--fine-gain-probe", "F", to(&a->fine_gain_probe, cli::toNonNegative),
      "the covariance and the trust flags follow the fine stage's re-association to its fixed "
      "point, measured with probes of F times the trust limits per axis (0.5 is the studied "
      "size; default 0: one Gauss-Newton step's covariance)")
      ->group(g);
  add(app, "--fine-settle-walk", "F", to(&a->fine_settle_walk, cli::toNonNegative),
      "the fine stage settles only where its updates' creep would carry the estimate on by less "
      "than F times the trust limits (default 0.25; LidarStereoSettings::fine_settle_walk)")
      ->group(g);
  add(app, "--cov-model-scale", "K", to(&a->cov_model_scale, cli::toNonNegative),
      "scales the covariance's model error (the common biases and per-axis floor; default 1, 0: "
      "without it)")
      ->group(g);
}

/// Study options of the left-right photometric solver.
void addStereoOptions(CLI::App* app, Args* a, const cli::ExpertOptions& expert) {
  const std::string g = expert.group("Left-right photometric solver");
  add(app, "--smooth-keypoints", "PX", to(&a->smooth_keypoints_px, cli::atLeast(0)),
      "full-resolution photometric key points only where the LiDAR depth is smooth within PX "
      "pixels (0: off)")
      ->group(g);
  add(app, "--depth-prior", "SIGMA", to(&a->depth_prior, cli::toNonNegative),
      "photometric key points' depth free at full resolution with a log-depth prior of SIGMA (0: "
      "the LiDAR's depth); co: the prior of the rounds with free depth")
      ->group(g);
}

/// Study options of co-calibration.
void addCoOptions(CLI::App* app, Args* a, const cli::ExpertOptions& expert) {
  const std::string g = expert.group("Co-calibration");
  add(app, "--free-depth-rounds", "N", to(&a->free_depth_rounds, cli::atLeast(0)),
      "co: photometric solves of rounds 1..N with free key point depth")
      ->group(g);
  add(app, "--lidar-first", "0|1", to(&a->lidar_first, cli::toSwitch),
      "co: the LiDAR-first fallback (default 0); its LiDAR-stereo search follows --search-deg")
      ->group(g);
  add(app, "--features", "0|1", to(&a->features, cli::toSwitch),
      "co: round 1 from the stereo pair of left-right feature matches, LiDAR first; its search "
      "follows --search-deg")
      ->group(g);
  add(app, "--co-halves-from-initial", "0|1", to(&a->co_halves, cli::toSwitch),
      "co: the final LiDAR estimate's halves also from the initial guess, whatever those from "
      "the estimate show (default 1)")
      ->group(g);
  add(app, "--propagate-stereo", "0|1", to(&a->propagate_stereo, cli::toSwitch),
      "co: the stereo pair's uncertainty in the LiDAR covariance (default 1)")
      ->group(g);
  add(app, "--rematch-deg", "X", to(&a->rematch_deg, cli::toDouble),
      "co: SGBM matches again beyond X deg about x/z (and 5 X of baseline direction) from its "
      "last matches, re-triangulates below (< 0: always matches again)")
      ->group(g);
  add(app, "--co-model-scale", "K", to(&a->co_model_scale, cli::toNonNegative),
      "scales co-calibration's model error (default 1)")
      ->group(g);
}

/// The values each option takes on its own: stages, windows, mode and method names.
bool checkChoices(const Args& a) {
  for (const auto& stage : cli::splitList(a.stages))
    if (stage != "coarse" && stage != "fine") {
      std::cerr << "tescalib_eval: --stages takes coarse, fine or coarse,fine (got '" << a.stages
                << "')\n";
      return false;
    }
  if (cli::splitList(a.stages).empty()) {
    std::cerr << "tescalib_eval: --stages is empty\n";
    return false;
  }
  if (a.windows != "first" && a.windows != "disjoint") {
    std::cerr << "tescalib_eval: --windows must be first or disjoint\n";
    return false;
  }
  if (a.sequences.empty()) {
    std::cerr << "tescalib_eval: --sequences is required\n";
    return false;
  }
  if (a.mode != "lidar_stereo" && a.mode != "stereo" && a.mode != "co" && a.mode != "joint") {
    std::cerr << "tescalib_eval: unknown mode '" << a.mode
              << "' (the modes: lidar_stereo, stereo, co, joint)\n";
    return false;
  }
  // The JSON's folder is checked before the trials run, not after them.
  if (const std::string folder = cli::missingFolder(a.json); !folder.empty()) {
    std::cerr << "tescalib_eval: --json: the folder \"" << folder << "\" does not exist\n";
    return false;
  }
  if (a.method != "tescalib" && a.method != "pcl_gicp" && a.method != "features") {
    std::cerr << "tescalib_eval: unknown method '" << a.method
              << "' (tescalib, pcl_gicp, features)\n";
    return false;
  }
  return true;
}

/// The combinations: baselines and options of one mode only, trial counts and seeds.
bool checkCombinations(const Args& a) {
  if (a.method == "pcl_gicp" && a.mode != "lidar_stereo") {
    std::cerr << "tescalib_eval: --method pcl_gicp registers LiDAR scans to stereo clouds: it is "
                 "a baseline of --mode lidar_stereo only (not of "
              << a.mode << ")\n";
    return false;
  }
  if (a.method == "features" && a.mode != "stereo") {
    std::cerr << "tescalib_eval: --method features estimates the stereo pair from left-right "
                 "feature matches: it is a baseline of --mode stereo only (not of "
              << a.mode << ")\n";
    return false;
  }
  if (a.trials < 1 || a.window < 1) {
    std::cerr << "tescalib_eval: --trials and --window must be positive\n";
    return false;
  }
  // Trial t's seed is seed * 1000003 + t, written to the JSON: it must stay exact there (2^53).
  const uint64_t last_trial = uint64_t(a.first_trial) + uint64_t(a.trials);
  if (last_trial > uint64_t(std::numeric_limits<int>::max()) ||
      a.seed > ((1ULL << 53) - last_trial) / 1000003ULL) {
    std::cerr
        << "tescalib_eval: --seed (at most about 9007170000), --first-trial and --trials are too "
           "large: trial t's seed, seed * 1000003 + t, must stay below 2^53\n";
    return false;
  }
  // Options of one mode only are refused rather than silently ignored.
  const bool lidar_options =
      a.lidar_rot_deg > 0 || a.lidar_trans_m > 0 || a.lidar_sigma_deg > 0 || a.lidar_sigma_m > 0;
  if (lidar_options && a.mode != "stereo") {
    std::cerr << "tescalib_eval: --lidar-rot-deg, --lidar-trans-m and --lidar-sigma are options "
                 "of --mode stereo (the LiDAR extrinsic the left-right solve is given), not of "
              << a.mode << "\n";
    return false;
  }
  if (a.stages != "coarse,fine" && a.mode != "lidar_stereo") {
    std::cerr << "tescalib_eval: --stages is an option of --mode lidar_stereo (co and joint run "
                 "their own stages), not of "
              << a.mode << "\n";
    return false;
  }
  return true;
}

}  // namespace

bool parse(int argc, char** argv, Args* a) {
  CLI::App app(kDescription, "tescalib_eval");
  cli::setUp(&app, kUsage, "Run");
  app.footer(kFooter);
  const cli::ExpertOptions expert(&app, argc, argv, "Run");
  addRunOptions(&app, a);
  addDataOptions(&app, a);
  addStereoModeOptions(&app, a);
  addKeyframeStudyOptions(&app, a, expert);
  addLidarStereoOptions(&app, a, expert);
  addStereoOptions(&app, a, expert);
  addCoOptions(&app, a, expert);
  return cli::parse(&app, argc, argv) && checkChoices(*a) && checkCombinations(*a);
}

}  // namespace tescalib::eval
