// One update of the LiDAR-stereo estimate from an association set: a few Ceres iterations of the
// coarse stage's eq. point_plane_normal_obj (Cauchy loss) or the fine stage's
// eq. point_point_normal_obj (Huber loss), over the pose perturbation [phi; tau] and, when
// estimated, the stereo clouds' scale and yaw.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/solvers/lidar_stereo_fixed_point.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {

/// What the coarse and the fine stage refine in turn, and hand on to the covariance.
struct LidarStereoEstimate {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  ///< T_cam_lidar
  double scale = 1.0;  ///< the stereo clouds' scale (held at 1 unless estimate_stereo_scale)
  double yaw = 0.0;    ///< the right camera's yaw, rad (held at 0 unless estimate_stereo_yaw)
  /// A Ceres update was not usable: the solve is not converged, and no later stage runs.
  bool solver_failed = false;
  bool settled = false;  ///< the fine stage's updates fell below fine_settle_* (or it is off)
  /// Where an unsettled fine stage was heading ([phi; tau], zero when it settled): the sum of its
  /// last half of updates and what their steady creep would still add. A direction the window
  /// does not hold, whatever the covariance says.
  Vector6d fine_drift = Vector6d::Zero();
  /// The fine stage's last association set: the residuals of the covariance.
  std::vector<LidarStereoAssociation> fine_associations;
  /// The LiDAR rings' range offsets (m, by range-image row: how much too long the ring's ranges
  /// are) the fine stage estimated with T (LidarStereoSettings::ring_range_sigma_m; empty when it
  /// does not).
  std::vector<double> ring_offsets;
  /// The fine stage's fixed-point gain where it settled (lidar_stereo_fixed_point.h; the
  /// identity, not determined, when not measured).
  FixedPointGain fixed_point;
};

/// Which objective an update minimises.
enum class LidarStereoObjective {
  kPointPlaneNormal,  ///< coarse stage, eq. point_plane_normal_obj, Cauchy loss
  kPointPointNormal,  ///< fine stage, eq. point_point_normal_obj, Huber loss
};

/// Solves the 6-DoF update [phi; tau] of T (perturbation about `t_ref`, the translation the
/// associations were made at) from `associations`, with the robust loss of scale `loss_scale`.
/// The clouds' `scale` and `yaw` are updated in place when they are estimated in this stage
/// (LidarStereoSettings::estimate_stereo_*, coarse_estimates_stereo_nuisances), within their
/// bounds. A failed solve (an infeasible bound, NaN residuals) returns NaN and leaves scale and
/// yaw as they were. With `ring_offsets` (the fine stage only) the rings' range offsets are
/// estimated too, from and into it (resized to the rings the associations span).
Vector6d solveLidarStereoUpdate(const std::vector<LidarStereoAssociation>& associations,
                                const Eigen::Vector3d& t_ref, LidarStereoObjective objective,
                                const LidarStereoSettings& settings, double loss_scale,
                                double* scale, double* yaw,
                                std::vector<double>* ring_offsets = nullptr);

}  // namespace tescalib
