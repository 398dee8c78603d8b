// Fine LiDAR-stereo residual, paper eq. (point_point_normal_obj):
//   r = n^T [ T (p_l + w_l) - F(d + w_c) ] / sigma,   n = R n_l (LiDAR normal in the camera frame)
// evaluated at the noise-free point; the noise enters through sigma (paper eq.
// residual_uncertainty):
//   sigma^2 = n^T R Sigma_l R^T n + (n^T dF/dd)^2 sigma_d^2,   dF/dd = -F(d) / d
// F(d) is the stereo point seen at the pixel where T p_l projects (projective association), held
// fixed during one solve and re-associated between solves.
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

struct LidarNormalResidual {
  LidarNormalResidual(const Eigen::Vector3d& q, const Eigen::Vector3d& m,
                      const Eigen::Vector3d& t_ref, const Eigen::Vector3d& p_s, double inv_sigma,
                      double d, double g)
      : q_(q), m_(m), t_ref_(t_ref), p_s_(p_s), inv_sigma_(inv_sigma), d_(d), g_(g) {}

  template <typename T>
  bool operator()(const T* const delta, const T* const scale, const T* const yaw,
                  T* residual) const {
    T n[3];
    const T k = correctedStereoScale(scale, yaw, d_, g_);
    const T dist = pointPlaneDistance(delta, &k, q_, m_, t_ref_, p_s_, n);
    residual[0] = dist * T(inv_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& q, const Eigen::Vector3d& m,
                                     const Eigen::Vector3d& t_ref, const Eigen::Vector3d& p_s,
                                     double inv_sigma, double d, double g) {
    return new ceres::AutoDiffCostFunction<LidarNormalResidual, 1, 6, 1, 1>(
        new LidarNormalResidual(q, m, t_ref, p_s, inv_sigma, d, g));
  }

 private:
  Eigen::Vector3d q_, m_, t_ref_, p_s_;
  double inv_sigma_, d_, g_;
};

}  // namespace tescalib
