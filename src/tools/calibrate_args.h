// tescalib_calibrate's command line: its options, their checks (the node's own parameter checks
// on the window this run uses) and the sliding window's size.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tescalib/ros/bag_sets.h"

namespace tescalib::calibrate {

struct Args {
  std::vector<std::string> sequences;
  std::string bag;
  BagTopics topics;
  std::string mode = "lidar_stereo";
  int window = 0;                    // 0: the node's (OnlineSettings::window_size)
  std::optional<int> min_keyframes;  // none: OnlineSettings' default (3)
  bool consistent_sample = false;    // LidarMeshSettings::consistent_sample
  std::string init;                  // --init FILE
  std::vector<double> init_pose;     // --init x,y,z,qx,qy,qz,qw: T_cam_lidar (the node's form)
  double perturb_rot_deg = 0, perturb_trans_m = 0;
  uint64_t seed = 1;
  int deskew = -1;     // -1: as the data say (KittiSequence::sweptScans)
  int align_rows = 1;  // OnlineSettings::align_rows
  int sgbm_paths = 3;  // StereoSettings::sgbm_paths (the keyframes' and co-calibration's clouds)
  int sgbm_both_ways = 1;  // StereoSettings::sgbm_both_ways (the same clouds)
  // StereoSettings::rectified_vertical_blur_px of the keyframes' clouds; < 0: the default
  double rectified_vertical_blur = -1;
  std::string out;
  std::string lidar_frame;  // empty: the bag's cloud frame, velo_link for folders
  std::string overlay;      // PNG: the last keyframe with the scan drawn, initial guess vs result
  double search_deg = -1;   // LidarStereoSettings::search_step_deg; < 0: the default (10)
  std::string bag_option;   // the last option of --bag only given (refused with --sequences)
  int split = 0;            // --split K: K disjoint windows solved on their own (0: off)
  int holdout = 0;          // --holdout N: every Nth keyframe held out and scored (0: off)
  std::string json;         // every estimate published or held back, with the monitor's state
  std::string monitor = "recalibrate";  // MonitorSettings::action
};

/// Reads and checks the command line into `a`; false after printing why (a usage error). --help
/// prints the options and exits.
bool parse(int argc, char** argv, Args* a);

/// The sliding window's size: --window, or the node's (OnlineSettings::window_size, window/size).
int windowSize(const Args& a);

}  // namespace tescalib::calibrate
