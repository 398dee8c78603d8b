// tescalib_validate's output: the table of scores (one row per calibration, one column per
// criterion, the difference to the best and whether it is significant), the per-axis directions
// and sensitivities, and the JSON file.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "tescalib/core/validation/optimum_uncertainty.h"
#include "tescalib/core/validation/validation.h"

namespace tescalib::validate {

/// One scored calibration.
struct Scored {
  std::string name;    ///< "recording" or the NAME of --calib
  std::string source;  ///< where it was read from
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  Validation validation;
  bool perturbed = false;  ///< a --perturbed row: scored without sensitivities
  bool has_optima = false;
  bool optima_held_out = false;  ///< the optima were searched on other frames than scored on
  std::array<Eigen::Isometry3d, kCriteria> optima;  ///< each criterion's optimum near it
  FrameScores optimum_scores;  ///< [c]: criterion c's per-frame scores at its optimum
  /// [c]: how well the frames it was searched on pin criterion c's optimum down.
  std::array<OptimumUncertainty, kCriteria> optimum_uncertainty;
};

/// The index of the best-scoring calibration for the criterion.
size_t bestOf(const std::vector<Scored>& all, Criterion c);

/// The table and the per-axis directions, as printed.
std::string scoreTable(const std::vector<Scored>& all, const ValidationSettings& settings);

/// The JSON document of --json (frames: "SEQUENCE:FRAME" labels).
nlohmann::json validationJson(const std::vector<Scored>& all, const ValidationSettings& settings,
                              const std::vector<std::string>& frames);

}  // namespace tescalib::validate
