// The frames a calibration is validated on, prepared once (edge maps, blurred grey images, depth
// discontinuities, stereo disparities), and the per-frame scores of the three criteria that do
// not share the solvers' objectives:
//   edge_alignment        LiDAR depth discontinuities on image edges, left and right image
//                         (edge_alignment.h); higher is better
//   photometric_residual  left vs right brightness at the LiDAR points' projections after an
//                         affine brightness fit (photometric_consistency.h); lower is better
//   disparity_residual    SGBM disparity vs the LiDAR-predicted one, mean truncated |difference|
//                         (lidarDisparityResidual, eval/); lower is better
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/stereo/stereo_cloud.h"
#include "tescalib/core/validation/edge_alignment.h"
#include "tescalib/core/validation/photometric_consistency.h"

namespace tescalib {

enum class Criterion : int { kEdgeAlignment = 0, kPhotometric = 1, kDisparity = 2 };
constexpr int kCriteria = 3;
constexpr std::array<Criterion, kCriteria> kAllCriteria = {
    Criterion::kEdgeAlignment, Criterion::kPhotometric, Criterion::kDisparity};

/// "edge_alignment", "photometric_residual", "disparity_residual".
const char* criterionName(Criterion c);
/// The score's unit ("", "grey levels", "px").
const char* criterionUnit(Criterion c);
bool higherIsBetter(Criterion c);

/// The model-error floors of the criteria's optima (ValidationSettings::optimum_floor).
std::array<Vector6d, kCriteria> defaultOptimumFloors();

struct ValidationSettings {
  EdgeAlignmentSettings edges;
  PhotometricConsistencySettings photometric;
  StereoSettings stereo;
  double step_rot_deg = 0.1;  ///< the finite-difference step of the sensitivities
  double step_trans_m = 0.01;
  int threads = 0;  ///< frames scored at the same time (0: one per core)
  /// [criterion]: the 1-sigma model-error floor of the criterion's optimum per axis [rad x3; m x3]
  /// (optimum_uncertainty.h), the rms distance of its optima from the truth on generated drives
  /// with real sensors' errors (doc/validation.md).
  std::array<Vector6d, kCriteria> optimum_floor = defaultOptimumFloors();
};

/// scores[criterion][frame].
using FrameScores = std::array<std::vector<double>, kCriteria>;

/// What the criteria need of one frame besides its scan and stereo cloud: both cameras' edge
/// maps and blurred grey images, and the scan's depth discontinuities.
struct PreparedFrame {
  cv::Mat edges_left, edges_right, grey_left, grey_right;
  std::vector<EdgePoint> discontinuities;
};

/// Prepares a frame from its images (8-bit, BGR or grey) and its scan.
PreparedFrame prepareFrame(const cv::Mat& left, const cv::Mat& right, const LidarScan& scan,
                           const ValidationSettings& settings);

/// One criterion's score on a prepared frame (`scan`: the frame's; `cloud`: its stereo cloud
/// with `T_right_left`, read by the disparity criterion only).
double preparedFrameScore(const PreparedFrame& p, const LidarScan& scan, const StereoCloud& cloud,
                          Criterion c, const StereoRig& rig, const Eigen::Isometry3d& T_cam_lidar,
                          const Eigen::Isometry3d& T_right_left,
                          const ValidationSettings& settings);

class ValidationSet {
 public:
  /// Prepares the frames (8-bit BGR pairs of the rig's size). Throws DataError when there is no
  /// frame or a frame's images do not fit the rig.
  ValidationSet(const std::vector<Frame>& frames, const StereoRig& rig,
                const ValidationSettings& settings = {});

  size_t size() const { return frames_.size(); }
  const StereoRig& rig() const { return rig_; }
  const ValidationSettings& settings() const { return settings_; }

  /// The per-frame scores of a calibration (only the criteria `use` holds; the others' vectors
  /// stay empty). The stereo disparities are recomputed when `T_right_left` differs from the
  /// last one scored with the disparity criterion.
  FrameScores score(const Eigen::Isometry3d& T_cam_lidar, const Eigen::Isometry3d& T_right_left,
                    const std::vector<Criterion>& use = {kAllCriteria.begin(), kAllCriteria.end()});

 private:
  struct Prepared {
    Frame frame;
    PreparedFrame prepared;
    StereoCloud cloud;
  };
  void updateClouds(const Eigen::Isometry3d& T_right_left);

  std::vector<Prepared> frames_;
  StereoRig rig_;
  ValidationSettings settings_;
  bool clouds_valid_ = false;
  Eigen::Isometry3d clouds_T_right_left_ = Eigen::Isometry3d::Identity();
};

}  // namespace tescalib
