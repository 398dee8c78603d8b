// Left-right photometric residual, paper eq. (Photometric_object_function):
//   r_k = sqrt(w_p) * ( I_r[p~_r] - b - e^a I_l[p~_l] ),   w_p = c^2 / (c^2 + |grad I_l(p)|^2)
// for the pixels p~_l of a key point's pattern N_p. Of the paper's four affine parameters
// (a_l, b_l, a_r, b_r) only the relative gain e^(a_r - a_l) and offset are observable from one
// pair: we fix the left ones (a_l = b_l = 0) and estimate a = a_r - a_l, b = b_r - e^a b_l per
// keyframe. Each pattern pixel's 3D point X (left camera frame) is where its ray meets the LiDAR
// face under the key point (eq. parametric_equation); it is projected into the right image with
// T_right_left = perturb(T_ref, delta): p~_r = K_r (Exp(phi) R_ref X + t_ref + tau).
// The Huber norm is applied by the solver as the loss function.
#pragma once

#include <array>

#include <ceres/ceres.h>
#include <ceres/cubic_interpolation.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

#include "tescalib/core/common/pinhole.h"

namespace tescalib {

constexpr int kPatternSize = 8;
/// Stereo DSO's 8-pixel residual pattern.
constexpr int kPattern[kPatternSize][2] = {{0, -2}, {-1, -1}, {1, -1}, {-2, 0},
                                           {0, 0},  {2, 0},   {-1, 1}, {0, 2}};

using ImageInterpolator = ceres::BiCubicInterpolator<ceres::Grid2D<double, 1>>;

struct PhotometricResidual {
  PhotometricResidual(const ImageInterpolator* right,
                      const std::array<Eigen::Vector3d, kPatternSize>& q,
                      const Eigen::Vector3d& t_ref,
                      const std::array<double, kPatternSize>& left_value, double sqrt_weight,
                      double fx, double fy, double cx, double cy)
      : right_(right),
        q_(q),
        t_ref_(t_ref),
        left_(left_value),
        sqrt_w_(sqrt_weight),
        fx_(fx),
        fy_(fy),
        cx_(cx),
        cy_(cy) {}

  template <typename T>
  bool operator()(const T* const delta, const T* const ab, T* residual) const {
    return evaluate(delta, ab, T(1), residual);
  }

  /// The residual with the key point's depth scaled by `depth_scale` (its pattern moves along
  /// the left rays, keeping the LiDAR face's orientation).
  template <typename T>
  bool evaluate(const T* const delta, const T* const ab, const T& depth_scale, T* residual) const {
    const T gain = ceres::exp(ab[0]);
    for (int k = 0; k < kPatternSize; ++k) {
      const T q[3] = {depth_scale * q_[k].x(), depth_scale * q_[k].y(), depth_scale * q_[k].z()};
      T y[3];
      ceres::AngleAxisRotatePoint(delta, q, y);
      for (int i = 0; i < 3; ++i) y[i] += T(t_ref_[i]) + delta[3 + i];
      if (y[2] < T(0.1)) return false;
      const Eigen::Matrix<T, 2, 1> px = projectPinhole(T(fx_), T(fy_), T(cx_), T(cy_), y);
      T value;
      right_->Evaluate(px.y(), px.x(), &value);
      residual[k] = T(sqrt_w_) * (value - ab[1] - gain * T(left_[k]));
    }
    return true;
  }

  static ceres::CostFunction* Create(const ImageInterpolator* right,
                                     const std::array<Eigen::Vector3d, kPatternSize>& q,
                                     const Eigen::Vector3d& t_ref,
                                     const std::array<double, kPatternSize>& left_value,
                                     double sqrt_weight, double fx, double fy, double cx,
                                     double cy) {
    return new ceres::AutoDiffCostFunction<PhotometricResidual, kPatternSize, 6, 2>(
        new PhotometricResidual(right, q, t_ref, left_value, sqrt_weight, fx, fy, cx, cy));
  }

 private:
  const ImageInterpolator* right_;
  std::array<Eigen::Vector3d, kPatternSize> q_;  ///< R_ref X per pattern pixel
  Eigen::Vector3d t_ref_;
  std::array<double, kPatternSize> left_;
  double sqrt_w_, fx_, fy_, cx_, cy_;
};

/// The same residual with the key point's log-depth correction rho as a parameter (depth
/// e^rho times the LiDAR's): with every key point's depth free, only the epipolar geometry
/// (vertical disparities) pins the baseline direction, not the LiDAR depth.
struct PhotometricDepthResidual {
  explicit PhotometricDepthResidual(const PhotometricResidual& r) : r_(r) {}
  template <typename T>
  bool operator()(const T* const delta, const T* const ab, const T* const rho, T* residual) const {
    return r_.evaluate(delta, ab, ceres::exp(rho[0]), residual);
  }
  static ceres::CostFunction* Create(const PhotometricResidual& r) {
    return new ceres::AutoDiffCostFunction<PhotometricDepthResidual, kPatternSize, 6, 2, 1>(
        new PhotometricDepthResidual(r));
  }

 private:
  PhotometricResidual r_;
};

/// Prior on a key point's log-depth correction when the LiDAR extrinsic's error is a nuisance
/// `xi` ([phi; tau], camera frame) shared by the key points: (rho - D xi) / sigma, D how the key
/// point's log depth follows the LiDAR extrinsic.
struct LogDepthLidarPrior {
  LogDepthLidarPrior(const Eigen::Matrix<double, 1, 6>& D, double sigma)
      : D_(D), inv_sigma_(1.0 / sigma) {}
  template <typename T>
  bool operator()(const T* const rho, const T* const xi, T* residual) const {
    T follows = T(0);
    for (int j = 0; j < 6; ++j) follows += T(D_[j]) * xi[j];
    residual[0] = (rho[0] - follows) * T(inv_sigma_);
    return true;
  }
  Eigen::Matrix<double, 1, 6> D_;
  double inv_sigma_;
};

/// Gaussian prior on the LiDAR extrinsic's error nuisance: xi_j / sigma_j.
struct LidarErrorPrior {
  explicit LidarErrorPrior(const Eigen::Matrix<double, 6, 1>& sigma)
      : inv_sigma_(sigma.cwiseInverse()) {}
  template <typename T>
  bool operator()(const T* const xi, T* residual) const {
    for (int j = 0; j < 6; ++j) residual[j] = xi[j] * T(inv_sigma_[j]);
    return true;
  }
  Eigen::Matrix<double, 6, 1> inv_sigma_;
};

}  // namespace tescalib
