#include "calibrate_args.h"

#include <cmath>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/ros/params.h"

#include "cli.h"

namespace tescalib::calibrate {

int windowSize(const Args& a) {
  const OnlineSettings defaults;
  return a.window > 0 ? a.window : defaults.window_size;
}

namespace {

const char* const kUsage =
    "usage: rosrun tescalib tescalib_calibrate --sequences DIR[,DIR...] | --bag FILE\n"
    "         [OPTIONS]";
const char* const kDescription =
    "Calibrates the recording in DIR (KITTI odometry or raw layout; several folders of one rig "
    "are played one after the other) or in a rosbag with the online pipeline.";
const char* const kFooter =
    "Exit status: 0 when an estimate converged, 1 when none did, the data are unusable or "
    "--overlay could not be written, 2 on a usage error.\n"
    "--help-expert also lists the options of the node's expert parameters (doc/offline.md).";

/// --init's x,y,z,qx,qy,qz,qw: seven finite numbers, the quaternion not zero (normalised when
/// used); anything else throws std::invalid_argument.
std::vector<double> initPose(const std::string& v) {
  std::vector<double> pose;
  std::stringstream in(v);
  for (std::string item; std::getline(in, item, ',');) pose.push_back(cli::toDouble(item));
  if (pose.size() != 7 || !(std::hypot(pose[3], pose[4], pose[5]) + std::fabs(pose[6]) > 1e-6))
    throw std::invalid_argument(v);
  return pose;
}

/// The recording: folders or a bag with its topics, the initial guess, de-skewing.
void addInputOptions(CLI::App* app, Args* a) {
  const char* g = "Input";
  cli::add(app, "--sequences", "DIR[,DIR...]",
           cli::to(&a->sequences, [](const std::string& v) { return cli::splitList(v); }),
           "KITTI folders (odometry or raw layout, or tescalib_simulate output) of one rig")
      ->group(g);
  cli::add(app, "--bag", "FILE", cli::to(&a->bag, cli::text),
           "a rosbag with kitti.launch's (kitti2bag's) topics, or those of --points, --left, "
           "--right. Initial guess: camera_info and /tf_static (left camera frame <- cloud "
           "frame), or --init")
      ->group(g);
  cli::add(app, "--points", "TOPIC", cli::to(&a->topics.points, cli::text),
           "--bag: the point cloud topic")
      ->group(g);
  cli::add(app, "--left", "IMAGE_TOPIC", cli::imageTopic(&a->topics.left, &a->topics.left_info),
           "--bag: the left image topic itself (the launch files take the namespace and image:= "
           "instead), sensor_msgs/Image or CompressedImage (.../compressed); camera_info is the "
           "image topic's folder + /camera_info")
      ->group(g);
  cli::add(app, "--right", "IMAGE_TOPIC", cli::imageTopic(&a->topics.right, &a->topics.right_info),
           "--bag: the right image topic, as --left")
      ->group(g);
  cli::add(app, "--max-skew", "S", cli::to(&a->topics.max_skew, cli::toDouble),
           "--bag: the largest time between a cloud and its images (default 0.05)")
      ->group(g);
  cli::add(
      app, "--init", "FILE|POSE",
      [a](const std::string& v) {
        if (v.find(',') == std::string::npos) return void(a->init = cli::text(v));
        a->init_pose = initPose(v);
      },
      "initial extrinsics from an earlier result (BASE.yaml) or a KITTI calib.txt (e.g. "
      "BASE_calib.txt); intrinsics stay the data's (DIR's calibration, a bag's camera_info). Or "
      "T_cam_lidar alone as x,y,z,qx,qy,qz,qw (m, quaternion: the node's initial/T_cam_lidar, as "
      "the printout's 'as the node's initial/T_cam_lidar' line gives it), the stereo pair the "
      "data's. Default: DIR's own calibration, a bag's /tf_static")
      ->group(g);
  cli::add(app, "--deskew", "0|1", cli::to(&a->deskew, cli::toSwitch),
           "motion-compensate the scans (default for folders: on for KITTI raw recordings and "
           "swept generated scans; for --bag: off, give --deskew 1 for a bag of raw driver "
           "sweeps such as kitti2bag's of a raw drive)")
      ->group(g);
}

/// The online calibrator's settings and the perturbed start.
void addCalibrationOptions(CLI::App* app, Args* a) {
  const char* g = "Calibration";
  cli::add(
      app, "--mode", "MODE", cli::to(&a->mode, cli::text),
      "lidar_stereo: T_cam_lidar only (the stereo pair as calibrated; default); co: both "
      "extrinsics (co-calibration, alternating the two solvers); joint: both in one least-squares "
      "problem (started from alternation rounds; its meshes fit every face's normal)")
      ->group(g);
  cli::add(app, "--window", "N", cli::to(&a->window, cli::toInt),
           "keyframes in the sliding window (default, or 0: the node's window/size, 10; co, "
           "joint: at least 5)")
      ->group(g);
  cli::add(app, "--min-keyframes", "N", cli::to(&a->min_keyframes, cli::toInt),
           "no solve before the window holds N keyframes (default 3, at most the window; the "
           "node's window/min_keyframes): fewer, better first estimates. co, joint: "
           "co-calibration waits for 5 keyframes in any case (LiDAR-stereo before)")
      ->group(g);
  cli::add(app, "--align-rows", "0|1", cli::to(&a->align_rows, cli::toSwitch),
           "re-rectify the pair once, before the first estimate, for the right camera's pitch "
           "and roll that the right image's rows show (default 1; the node's stereo/align_rows)")
      ->group(g);
  cli::add(app, "--sgbm-paths", "3|5|8", cli::to(&a->sgbm_paths, cli::toSgbmPaths),
           "SGBM's aggregation paths (default 3; the node's stereo/sgbm_paths): 8 also "
           "aggregates from below, which keeps the road's disparity from matching as if shifted "
           "upwards, at about 3x the stereo time")
      ->group(g);
  cli::add(app, "--sgbm-both-ways", "0|1", cli::to(&a->sgbm_both_ways, cli::toSwitch),
           "match each pair upright and upside down and keep the mean (default 1; the node's "
           "stereo/sgbm_both_ways): the road's disparity does not shift, at 2x the matching time")
      ->group(g);
  cli::add(app, "--rectified-vertical-blur", "PX",
           cli::to(&a->rectified_vertical_blur, cli::toNonNegative),
           "the keyframes' clouds: a low-pass along the columns (Gaussian sigma, px) of both "
           "images of a re-rectified pair before matching (default 0.8; the node's "
           "stereo/rectified_vertical_blur_px; 0: off; co's re-matched clouds: off)")
      ->group(g);
  cli::add(app, "--perturb-rot-deg", "R", cli::to(&a->perturb_rot_deg, cli::toDouble),
           "with --perturb-trans-m (either or both): start that far from the initial "
           "T_cam_lidar (random direction, --seed); the errors against that initial guess (DIR's "
           "calibration, a bag's /tf_static, or --init) are then printed, with each estimate's "
           "NEES (e^T P^-1 e, 6 DoF: does its covariance cover the error?)")
      ->group(g);
  cli::add(app, "--perturb-trans-m", "T", cli::to(&a->perturb_trans_m, cli::toDouble),
           "see --perturb-rot-deg")
      ->group(g);
  cli::add(app, "--seed", "S", cli::to(&a->seed, cli::toSeed),
           "the perturbation's random direction (default 1)")
      ->group(g);
  cli::add(app, "--split", "K", cli::to(&a->split, cli::atLeast(2)),
           "repeatability: calibrate K disjoint parts of the recording's keyframes on their own "
           "and print every pair's difference against their covariances (chi2, 6 DoF); "
           "--sequences only, without --out and --overlay")
      ->group(g);
  cli::add(app, "--holdout", "N", cli::to(&a->holdout, cli::atLeast(2)),
           "keep every Nth keyframe out of the calibration and score the estimate, the initial "
           "guess and the recording's calibration on those (doc/validation.md); with --out, "
           "written into BASE.yaml (quality: held_out:)")
      ->group(g);
}

/// Options of the node's expert parameters (doc/parameters.md), for studies.
void addExpertOptions(CLI::App* app, Args* a, const cli::ExpertOptions& expert) {
  const std::string g = expert.group("Calibration");
  cli::add(app, "--consistent-sample", "0|1", cli::to(&a->consistent_sample, cli::toSwitch),
           "draw the meshes' faces by their place in the range image: the estimates depend much "
           "less on the estimate each keyframe's mesh was built with (default 0; the node's "
           "lidar_stereo/consistent_sample)")
      ->group(g);
  cli::add(app, "--search-deg", "D", cli::to(&a->search_deg, cli::toNonNegative),
           "before the first estimate, a LiDAR-stereo solve that does not converge is tried "
           "again from the start turned +-D deg about the camera's x and y axes (default 10; 0: "
           "off; the node's lidar_stereo/search_deg)")
      ->group(g);
}

/// Where the result goes.
void addOutputOptions(CLI::App* app, Args* a) {
  const char* g = "Output";
  cli::add(app, "--out", "BASE", cli::to(&a->out, cli::text),
           "write the last converged estimate to BASE.yaml, BASE_calib.txt and "
           "BASE_static_tf.launch (nothing is written when none converged)")
      ->group(g);
  cli::add(app, "--lidar-frame", "NAME", cli::to(&a->lidar_frame, cli::text),
           "the LiDAR's tf frame in --out's files (default: a bag's cloud frame_id, velo_link "
           "for folders, as kitti2bag; the cameras are tescalib_left and tescalib_right, as the "
           "node publishes them)")
      ->group(g);
  cli::add(app, "--overlay", "FILE.png", cli::to(&a->overlay, cli::text),
           "the last keyframe's left image twice, the scan drawn with the initial T_cam_lidar "
           "(top) and with the estimate (bottom; without one, the last solve's, labelled NOT "
           "TRUSTED), to look at the alignment without ROS")
      ->group(g);
  cli::add(app, "--json", "FILE", cli::to(&a->json, cli::text),
           "every estimate the node would publish or hold back: {\"estimates\": [{\"time\", "
           "\"extrinsic\", \"published\", \"T\" [16], \"covariance\" [36], \"monitor\"}]}")
      ->group(g);
  cli::add(
      app, "--monitor", "ACTION",
      [a](const std::string& v) {
        if (v != "recalibrate" && v != "flag" && v != "off")
          throw CLI::ValidationError("--monitor must be recalibrate, flag or off, not '" + v + "'");
        a->monitor = v;
      },
      "the calibration monitor's action on a changed extrinsic (monitor/action): recalibrate "
      "(default), flag (only report) or off")
      ->group(g);
}

/// The input, the mode and the window: the node's own parameter checks (validateNodeParams) on
/// the window this run uses.
bool checkRun(const Args& a) {
  if (a.sequences.empty() == a.bag.empty()) {
    std::cerr << "tescalib_calibrate: give exactly one of --sequences and --bag\n";
    return false;
  }
  if (a.mode != "lidar_stereo" && a.mode != "co" && a.mode != "joint") {
    std::cerr << "tescalib_calibrate: --mode must be lidar_stereo, co or joint\n";
    return false;
  }
  if (a.window < 0 || a.window == 1 || a.window == 2) {
    std::cerr << "tescalib_calibrate: --window must be at least 3\n";
    return false;
  }
  const int window = windowSize(a);
  const OnlineSettings defaults;
  const int min_co = defaults.min_keyframes_co;
  if (a.mode != "lidar_stereo" && window < min_co) {
    std::cerr << "tescalib_calibrate: --mode " << a.mode << " needs --window " << min_co
              << " or more (co-calibration waits for " << min_co << " keyframes)\n";
    return false;
  }
  if (a.min_keyframes && (*a.min_keyframes < 1 || *a.min_keyframes > window)) {
    std::cerr << "tescalib_calibrate: --min-keyframes must be between 1 and the window (" << window
              << ")\n";
    return false;
  }
  if (a.search_deg > LidarStereoSettings::kMaxSearchStepDeg) {
    std::cerr << "tescalib_calibrate: --search-deg must be between 0 (off) and "
              << LidarStereoSettings::kMaxSearchStepDeg << "\n";
    return false;
  }
  if (a.perturb_rot_deg < 0 || a.perturb_trans_m < 0) {
    std::cerr << "tescalib_calibrate: perturbations are sizes (>= 0)\n";
    return false;
  }
  if (!(a.topics.max_skew > 0)) {
    std::cerr << "tescalib_calibrate: --max-skew must be > 0 s\n";
    return false;
  }
  return true;
}

/// Options that would be silently ignored (bag topics for folders, a frame name without files to
/// write it into) and where the results go, checked before the work rather than after it.
bool checkOutputs(const Args& a) {
  if (a.split > 0 && (!a.bag.empty() || !a.out.empty() || !a.overlay.empty())) {
    std::cerr << "tescalib_calibrate: --split goes with --sequences, without --out and --overlay "
                 "(it writes no result)\n";
    return false;
  }
  if (a.split > 0 && a.holdout > 0) {
    std::cerr << "tescalib_calibrate: --holdout does not go with --split\n";
    return false;
  }
  if (!a.sequences.empty() && !a.bag_option.empty()) {
    std::cerr << "tescalib_calibrate: " << a.bag_option
              << " is an option of --bag, not of --sequences\n";
    return false;
  }
  if (!a.lidar_frame.empty() && a.out.empty()) {
    std::cerr << "tescalib_calibrate: --lidar-frame names the LiDAR frame in --out's files: give "
                 "--out\n";
    return false;
  }
  if (!a.out.empty()) {
    if (const std::string problem = calibrationBaseProblem(a.out); !problem.empty()) {
      std::cerr << "tescalib_calibrate: --out " << problem << "\n";
      return false;
    }
    if (const std::string folder = cli::missingFolder(a.out); !folder.empty()) {
      std::cerr << "tescalib_calibrate: --out: the folder \"" << folder << "\" does not exist\n";
      return false;
    }
  }
  if (const std::string folder = cli::missingFolder(a.overlay); !folder.empty()) {
    std::cerr << "tescalib_calibrate: --overlay: the folder \"" << folder << "\" does not exist\n";
    return false;
  }
  if (!a.overlay.empty() && !cv::haveImageWriter(a.overlay)) {
    std::cerr << "tescalib_calibrate: --overlay: OpenCV cannot write \"" << a.overlay
              << "\" (give a .png file name)\n";
    return false;
  }
  return true;
}

}  // namespace

bool parse(int argc, char** argv, Args* a) {
  CLI::App app(kDescription, "tescalib_calibrate");
  cli::setUp(&app, kUsage, "Input");
  app.footer(kFooter);
  const cli::ExpertOptions expert(&app, argc, argv, "Input");
  addInputOptions(&app, a);
  addCalibrationOptions(&app, a);
  addOutputOptions(&app, a);
  addExpertOptions(&app, a, expert);
  if (!cli::parse(&app, argc, argv)) return false;
  for (const CLI::Option* opt : app.parse_order())  // the last option of --bag only given
    for (const char* name : {"--points", "--left", "--right", "--max-skew"})
      if (opt->get_name() == name) a->bag_option = name;
  return checkRun(*a) && checkOutputs(*a);
}

}  // namespace tescalib::calibrate
