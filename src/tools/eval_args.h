// tescalib_eval's command line: the options of the evaluation contract (doc/evaluation.md) and
// the study options of the solvers' settings.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace tescalib::eval {

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
  std::string score_estimates;  ///< tescalib_calibrate --json FILE to score instead of trials
  std::string stages = "coarse,fine";
  int cov_cells_x = -1, cov_cells_y = -1;  ///< -1: the solver default
  double ring_range_sigma = -1;    ///< LidarStereoSettings::ring_range_sigma_m; < 0: default
  double fine_settle_walk = -1;    ///< LidarStereoSettings::fine_settle_walk; < 0: default
  double fine_gain_probe = -1;     ///< LidarStereoSettings::fine_gain_probe; < 0: default
  int fine_stereo_normal_px = -1;  ///< LidarStereoSettings::fine_stereo_normal_px; < 0: default
  int ring_clusters = -1;          ///< LidarStereoSettings::ring_cluster_rings; -1: default
  int align_rows = 1;  ///< 1: re-rectify with the rows of keyframe 0 (rowAlignedExtrinsic)
  int smooth_keypoints_px = -1;  ///< photometric smooth_depth_radius_px; -1: the solver default
  double depth_prior = -1;       ///< photometric depth_prior_sigma; < 0: the solver default
  /// stereo mode: 1-sigma per axis of the given LiDAR extrinsic (deg, m), propagated into the
  /// left-right covariance (addLidarUncertainty); 0: taken as exact.
  double lidar_sigma_deg = 0, lidar_sigma_m = 0;
  int free_depth_rounds = -1;  ///< co: CoCalibrationSettings::free_depth_rounds; < 0: default
  int lidar_first = -1;        ///< co: CoCalibrationSettings::lidar_first_fallback; < 0: default
  int propagate_stereo =
      -1;                  ///< co: CoCalibrationSettings::propagate_stereo_into_lidar; < 0: default
  int features = -1;       ///< co: CoCalibrationSettings::stereo_from_features; < 0: default
  int co_halves = -1;      ///< co: the halves from the initial guess too (0/1); < 0: default
  double rematch_deg = 0;  ///< co: CoCalibrationSettings::rematch_deg; 0: the default
  double co_model_scale = -1;  ///< scales CoCalibrationSettings::model_sigma_*; -1: as is
  int stereo_yaw = -1;      ///< LiDAR-stereo estimates the right camera's yaw: 0/1; -1: the default
  int stereo_scale = -1;    ///< LiDAR-stereo mode estimates the clouds' scale: 0/1; -1: the default
  int check_halves = -1;    ///< LidarStereoSettings::check_window_halves: 0/1; -1: the default
  int halves_start = -1;    ///< LidarStereoSettings::halves_start (HalvesStart); -1: the default
  int measure_offset = -1;  ///< LidarStereoSettings::measure_disparity_offset: 0/1; -1: the default
  int coarse_nuisances = -1;  ///< LidarStereoSettings::coarse_estimates_stereo_nuisances: 0/1
  std::vector<double> coarse_gates;  ///< LidarStereoSettings::coarse_gates; empty: the default
  double search_deg = -1;            ///< LidarStereoSettings::search_step_deg; < 0: the default
  int refine_iterations = -1;        ///< DisparityRefinementSettings::iterations; -1: the default
  int refine_smoothed = -1;          ///< DisparityRefinementSettings::smoothed_gradient_rounds
  int sgbm_paths = 3;                ///< StereoSettings::sgbm_paths of every stereo cloud
  bool sgbm_both_ways = true;        ///< StereoSettings::sgbm_both_ways of every stereo cloud
  /// StereoSettings::rectified_vertical_blur_px of the keyframes' clouds; < 0: the default
  double rectified_vertical_blur = -1;
  /// De-skew the scans with the motion registered against a neighbouring frame: 0/1; -1: when
  /// the sequence's scans are swept (sweptScans).
  int deskew = -1;
  bool consistent_sample = false;  ///< LidarMeshSettings::consistent_sample
  /// Keep every Nth laser ring of each scan (renumbered 0, 1, ...): a sparser LiDAR from the same
  /// drive (a 64-ring scan with N = 4: 16 rings 1.7 deg apart, about a VLP-16's 2 deg).
  int keep_rings = 1;
  double cov_model_scale = -1;    ///< scales the solver's model-error sigmas (0: none)
  std::string windows = "first";  ///< first: the first W keyframes; disjoint: every W in turn
};

/// Parses argv into `a` (--help prints the options and exits); false (with the reason on stderr)
/// for an unknown option, a bad value or a combination the tool refuses.
bool parse(int argc, char** argv, Args* a);

}  // namespace tescalib::eval
