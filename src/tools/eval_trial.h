// tescalib_eval's trials: one solve per perturbed initial guess, and what each trial measured
// against the ground truth.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/uncertainty/trust.h"

#include "eval_args.h"
#include "eval_data.h"

namespace tescalib::eval {

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
  LidarStereoBiasSensitivity bias = LidarStereoBiasSensitivity::Constant(std::nan(""));
  /// LidarStereoResult::fixed_point_contraction where the gain was measured (--fine-gain-probe).
  double fixed_point_contraction = std::nan("");
  /// Within the success thresholds of the evaluation contract: < 0.2 deg and < 3 cm.
  bool success() const {
    return err.head<3>().norm() * kDegPerRad < 0.2 && err.tail<3>().norm() < 0.03;
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
  int iterations = 0;      ///< solver iterations; co/joint: rounds
  int rematches = -1;      ///< co/joint: keyframe clouds matched again (SGBM)
  int yaw_handovers = -1;  ///< co: restarts at the LiDAR-stereo yaw (CoCalibrationResult)
  int lidar_first = -1;    ///< co: 1 when the LiDAR-first fallback ran (CoCalibrationResult)
  int search_starts = -1;  ///< lidar_stereo: LidarStereoResult::search_starts
  double stereo_scale = std::nan(""), stereo_scale_sigma = std::nan("");  ///< when estimated
  double stereo_yaw_deg = std::nan("");  ///< the clouds' yaw, when LiDAR-stereo mode estimates it
  double disparity_offset_px = std::nan("");  ///< LidarStereoResult::disparity_offset_px, measured
  double disparity_offset_sigma_px = std::nan("");
  bool disparity_offset_used = false;  ///< determined and beyond the model: the bias term uses it
  LidarStereoResult::Halves halves;    ///< the LiDAR-stereo split-window check
  WeakDirection lidar_weakest;         ///< LidarStereoResult::weakest (ratio 0: none)
  WeakDirection stereo_weakest;        ///< PhotometricResult::weakest (ratio 0: none)
  std::vector<std::pair<std::string, double>> stage_seconds;  ///< co/joint: time per solve stage
  std::vector<Eigen::Vector2d> brightness;                    ///< stereo mode: per keyframe (a, b)
  /// stereo mode with the LiDAR error nuisance: PhotometricResult::lidar_error (NaN: none)
  Vector6d lidar_error_found = Vector6d::Constant(std::nan(""));
  std::string message;
};

/// The LiDAR-stereo solver's settings with the command line's study options.
LidarStereoSettings lidarSettings(const Args& args, const KeyframeSettings& kfs);
/// Trial `t`: its initial guess (seeded by --seed and t), its window's meshes, the solve, and
/// the errors and NEES against the ground truth.
Trial runTrial(const Args& args, int t, const LidarStereoSettings& solver_settings, EvalData* d);
/// The trial's row of the table (and the stereo row in co / joint mode).
void printTrialHeader();
void printTrial(const Args& args, int t, const Trial& tr);

}  // namespace tescalib::eval
