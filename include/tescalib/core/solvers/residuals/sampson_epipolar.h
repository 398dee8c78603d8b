// Epipolar residual of one left-right correspondence, in pixels (Sampson's first-order distance;
// Hartley and Zisserman, eq. 11.9):
//   e = x_r^T E x_l,  E = [t]x R,  r = f e / sqrt((E x_l)_1^2 + (E x_l)_2^2 + (E^T x_r)_1^2 +
//   (E^T x_r)_2^2)
// with x_l, x_r normalised image coordinates (K^-1 [u v 1]^T) and f the focal length that turns
// them back into pixels. It needs no depth: the rotation R and the baseline direction t (unit) of
// T_right_left = [R | t] are what a set of matches constrains (the length is not observable).
// `phi` is a rotation vector applied on the left of R0 (R = Exp(phi) R0).
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

namespace tescalib {

struct SampsonEpipolarResidual {
  SampsonEpipolarResidual(const Eigen::Vector3d& x_l, const Eigen::Vector3d& x_r,
                          const Eigen::Matrix3d& R0, double focal)
      : x_l0_(R0 * x_l), x_r_(x_r), R0t_(R0.transpose()), focal_(focal) {}

  template <typename T>
  bool operator()(const T* const phi, const T* const t, T* residual) const {
    const T p[3] = {T(x_l0_.x()), T(x_l0_.y()), T(x_l0_.z())};
    T Rx[3];
    ceres::AngleAxisRotatePoint(phi, p, Rx);
    // E x_l = t x (R x_l)
    const T Ex[3] = {t[1] * Rx[2] - t[2] * Rx[1], t[2] * Rx[0] - t[0] * Rx[2],
                     t[0] * Rx[1] - t[1] * Rx[0]};
    const T xr[3] = {T(x_r_.x()), T(x_r_.y()), T(x_r_.z())};
    const T e = xr[0] * Ex[0] + xr[1] * Ex[1] + xr[2] * Ex[2];
    // E^T x_r = R^T (x_r x t), only its first two components: R^T applied through -phi.
    const T c[3] = {xr[1] * t[2] - xr[2] * t[1], xr[2] * t[0] - xr[0] * t[2],
                    xr[0] * t[1] - xr[1] * t[0]};
    const T minus_phi[3] = {-phi[0], -phi[1], -phi[2]};
    T Etx0[3];  // in the R0-rotated left frame; R0^T brings it to the left camera's
    ceres::AngleAxisRotatePoint(minus_phi, c, Etx0);
    T Etx[3];
    for (int i = 0; i < 3; ++i)
      Etx[i] = T(R0t_(i, 0)) * Etx0[0] + T(R0t_(i, 1)) * Etx0[1] + T(R0t_(i, 2)) * Etx0[2];
    const T den = Ex[0] * Ex[0] + Ex[1] * Ex[1] + Etx[0] * Etx[0] + Etx[1] * Etx[1];
    residual[0] = T(focal_) * e / sqrt(den + T(1e-300));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& x_l, const Eigen::Vector3d& x_r,
                                     const Eigen::Matrix3d& R0, double focal) {
    return new ceres::AutoDiffCostFunction<SampsonEpipolarResidual, 1, 3, 3>(
        new SampsonEpipolarResidual(x_l, x_r, R0, focal));
  }

 private:
  Eigen::Vector3d x_l0_;  ///< R0 x_l: R x_l = Exp(phi) (R0 x_l)
  Eigen::Vector3d x_r_;
  Eigen::Matrix3d R0t_;
  double focal_;
};

}  // namespace tescalib
