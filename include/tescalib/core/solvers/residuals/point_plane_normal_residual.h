// Coarse LiDAR-stereo residual, paper eq. (point_plane_normal_obj):
//   r = [ n_m^T (T p_m - p_s) / sigma ;  w * (R n_m) x n_s ]
// with p_m / n_m the centroid / normal of a LiDAR face (LiDAR frame) and p_s / n_s the associated
// stereo point / normal (camera frame). The paper writes n_m^T (T p_m - p_s) with the LiDAR normal
// still in the LiDAR frame; it must be rotated into the camera frame (R n_m), which we do.
// sigma is the noise-model standard deviation of the point-to-plane distance (an addition to the
// paper, see lidar_stereo_solver.cpp). The pose is T = perturb(T_ref, [phi; tau]): the reference
// rotation is applied to p_m and n_m beforehand (q = R_ref p_m, m = R_ref n_m).
// `scale` multiplies the stereo point: 1 and held constant when the stereo baseline is trusted;
// estimated in co-calibration, where the LiDAR gives the stereo pair its metric scale (an addition
// to the paper: a wrong baseline scales the whole stereo cloud, which no rigid T can absorb).
// `yaw` is a rotation of the right camera about its y axis relative to the rectification the
// cloud was computed with: it shifts the point's disparity d by g yaw, g = f (1 + x_r^2), the
// point scales with d / (d + g yaw). 0 and held constant unless LidarStereoSettings::
// estimate_stereo_yaw (see correctedStereoScale).
#pragma once

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "tescalib/core/solvers/residuals/point_plane_distance.h"

namespace tescalib {

struct PointPlaneNormalResidual {
  PointPlaneNormalResidual(const Eigen::Vector3d& q, const Eigen::Vector3d& m,
                           const Eigen::Vector3d& t_ref, const Eigen::Vector3d& p_s,
                           const Eigen::Vector3d& n_s, double inv_sigma, double normal_weight,
                           double d, double g)
      : q_(q),
        m_(m),
        t_ref_(t_ref),
        p_s_(p_s),
        n_s_(n_s),
        inv_sigma_(inv_sigma),
        w_(normal_weight),
        d_(d),
        g_(g) {}

  template <typename T>
  bool operator()(const T* const delta, const T* const scale, const T* const yaw,
                  T* residual) const {
    T n[3];
    const T k = correctedStereoScale(scale, yaw, d_, g_);
    const T dist = pointPlaneDistance(delta, &k, q_, m_, t_ref_, p_s_, n);
    residual[0] = dist * T(inv_sigma_);
    residual[1] = T(w_) * (n[1] * T(n_s_.z()) - n[2] * T(n_s_.y()));
    residual[2] = T(w_) * (n[2] * T(n_s_.x()) - n[0] * T(n_s_.z()));
    residual[3] = T(w_) * (n[0] * T(n_s_.y()) - n[1] * T(n_s_.x()));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& q, const Eigen::Vector3d& m,
                                     const Eigen::Vector3d& t_ref, const Eigen::Vector3d& p_s,
                                     const Eigen::Vector3d& n_s, double inv_sigma,
                                     double normal_weight, double d, double g) {
    return new ceres::AutoDiffCostFunction<PointPlaneNormalResidual, 4, 6, 1, 1>(
        new PointPlaneNormalResidual(q, m, t_ref, p_s, n_s, inv_sigma, normal_weight, d, g));
  }

 private:
  Eigen::Vector3d q_, m_, t_ref_, p_s_, n_s_;
  double inv_sigma_, w_, d_, g_;
};

}  // namespace tescalib
