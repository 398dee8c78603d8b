// The fine LiDAR-stereo residual (LidarNormalResidual) with the range offsets of the two LiDAR
// rings the face spans (LidarStereoSettings::ring_range_sigma_m): a ring whose ranges are o too
// long has its points o too far along their beams, and the true face lies back from the measured
// one by its vertices' shares of that along the centroid's beam (the vertices' beams are within a
// fraction of a degree of it), so
//   r = [ dist - g (s_lo o_lo + s_hi o_hi) ] / sigma
// with g the face's range_gain n_l^T b (LidarStereoAssociation; in the LiDAR frame, which the
// pose's rotation does not change) and s_lo, s_hi its vertices' shares of the two rings. The
// offsets' priors are ScalarPrior (residuals/scalar_prior.h) and RingOffsetMean.
#pragma once

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/solvers/residuals/point_plane_distance.h"

namespace tescalib {

struct LidarRingOffsetResidual {
  LidarRingOffsetResidual(const LidarStereoAssociation& a, const Eigen::Vector3d& t_ref)
      : q_(a.q),
        m_(a.m),
        t_ref_(t_ref),
        p_s_(a.p_s),
        inv_sigma_(a.inv_sigma),
        d_(a.d),
        g_(a.g),
        gain_lo_(a.range_gain * a.lower_share),
        gain_hi_(a.range_gain * (1.0 - a.lower_share)) {}

  template <typename T>
  bool operator()(const T* const delta, const T* const scale, const T* const yaw,
                  const T* const offset_lo, const T* const offset_hi, T* residual) const {
    T n[3];
    const T k = correctedStereoScale(scale, yaw, d_, g_);
    const T dist = pointPlaneDistance(delta, &k, q_, m_, t_ref_, p_s_, n);
    residual[0] = (dist - T(gain_lo_) * offset_lo[0] - T(gain_hi_) * offset_hi[0]) * T(inv_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(const LidarStereoAssociation& a,
                                     const Eigen::Vector3d& t_ref) {
    return new ceres::AutoDiffCostFunction<LidarRingOffsetResidual, 1, 6, 1, 1, 1, 1>(
        new LidarRingOffsetResidual(a, t_ref));
  }

 private:
  Eigen::Vector3d q_, m_, t_ref_, p_s_;
  double inv_sigma_, d_, g_, gain_lo_, gain_hi_;
};

/// The mean of the rings' range offsets, held near 0 (mean / sigma): the common part of the rings'
/// offsets moves every face in view along its beam, as the camera's optical axis does, and is
/// the window-common range bias of the covariance's model error (LidarStereoSettings::
/// model_sigma_range_m) rather than a parameter. One 1-D parameter block per ring.
class RingOffsetMean : public ceres::CostFunction {
 public:
  RingOffsetMean(int rings, double sigma) : gain_(1.0 / (rings * sigma)) {
    set_num_residuals(1);
    for (int i = 0; i < rings; ++i) mutable_parameter_block_sizes()->push_back(1);
  }

  bool Evaluate(double const* const* offsets, double* residual, double** jacobians) const override {
    const size_t n = parameter_block_sizes().size();
    residual[0] = 0;
    for (size_t i = 0; i < n; ++i) residual[0] += offsets[i][0] * gain_;
    if (jacobians)
      for (size_t i = 0; i < n; ++i)
        if (jacobians[i]) jacobians[i][0] = gain_;
    return true;
  }

 private:
  double gain_;
};

}  // namespace tescalib
