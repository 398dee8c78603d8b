// The joint calibration's residuals (solvers/joint_calibration.h): both depend on both
// extrinsics, T_cam_lidar = perturb(T_cl_ref, d_cl) and T_right_left = perturb(T_rl_ref, d_rl).
#pragma once

#include <array>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Core>

#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/solvers/residuals/photometric_residual.h"

namespace tescalib {

/// LiDAR fine residual, paper eq. point_point_normal_obj, r = n^T (T p_l - F(d')) / sigma, with
/// the stereo point F linearised in T_right_left (see the header): its baseline is |t_rl| (exact:
/// F scales with it), and its disparity d' = d + f dx corrects to first order for the rotation
/// phi between the right camera of the estimate and the one the cloud was rectified with:
/// a right camera rotated by phi sees the point at x_r + dx,
///   dx = phi_y (1 + x_r^2) - phi_z y - phi_x x_r y   (x_r, y: normalised right coordinates),
/// so SGBM measured d - f dx. (The rectification rotations themselves are tenths of a degree:
/// phi is taken in the rectified right frame; phi's lever on the baseline direction is left to
/// re-rectification.)
struct JointLidarResidual {
  Eigen::Vector3d q, m, t;  ///< R_cl p_l, R_cl n_l, t_cl (reference)
  double u, v, d;           ///< rectified pixel and measured disparity
  double fx, fy, cx, cy;
  Eigen::Matrix3d R_rect;
  Eigen::Vector3d t_rl;  ///< reference left-right translation
  Eigen::Vector3d phi0;  ///< rotation of the reference right camera from the clouds' one
  double inv_sigma;

  template <typename T>
  bool operator()(const T* const d_cl, const T* const d_rl, T* residual) const {
    T b2 = T(0);
    for (int i = 0; i < 3; ++i) b2 += (T(t_rl[i]) + d_rl[3 + i]) * (T(t_rl[i]) + d_rl[3 + i]);
    const T phi[3] = {d_rl[0] + T(phi0.x()), d_rl[1] + T(phi0.y()), d_rl[2] + T(phi0.z())};
    const Eigen::Vector3d ray_r = pinholeRay(fx, fy, cx, cy, u - d, v);
    const double xr = ray_r.x(), y = ray_r.y();
    const T dx = phi[1] * (1.0 + xr * xr) - phi[2] * y - phi[0] * xr * y;
    const T disp = T(d) + T(fx) * dx;
    if (disp < T(0.5)) return false;
    const T Z = T(fx) * ceres::sqrt(b2) / disp;
    const Eigen::Vector3d ray_l = pinholeRay(fx, fy, cx, cy, u, v);
    const T pr[3] = {T(ray_l.x()) * Z, T(ray_l.y()) * Z, Z};
    Eigen::Matrix<T, 3, 1> p;
    for (int i = 0; i < 3; ++i)
      p[i] = T(R_rect(0, i)) * pr[0] + T(R_rect(1, i)) * pr[1] + T(R_rect(2, i)) * pr[2];
    const T qq[3] = {T(q.x()), T(q.y()), T(q.z())};
    const T mm[3] = {T(m.x()), T(m.y()), T(m.z())};
    T c[3], n[3];
    ceres::AngleAxisRotatePoint(d_cl, qq, c);
    ceres::AngleAxisRotatePoint(d_cl, mm, n);
    T dist = T(0);
    for (int i = 0; i < 3; ++i) dist += n[i] * (c[i] + T(t[i]) + d_cl[3 + i] - p[i]);
    residual[0] = dist * T(inv_sigma);
    return true;
  }
};

/// Photometric residual (as PhotometricResidual) whose pattern points are the intersections of
/// the left rays with the key point's LiDAR face under T_cam_lidar = perturb(T_cl_ref, d_cl).
struct JointPhotometricResidual {
  const ImageInterpolator* right;
  std::array<Eigen::Vector3d, kPatternSize> rays;  ///< left rays (z = 1)
  Eigen::Vector3d q_f, m_f, t_cl;                  ///< R_cl p_face, R_cl n_face, t_cl (reference)
  Eigen::Matrix3d R_rl;
  Eigen::Vector3d t_rl;
  std::array<double, kPatternSize> left;
  double sqrt_w, fx, fy, cx, cy;

  template <typename T>
  bool operator()(const T* const d_rl, const T* const ab, const T* const d_cl, T* residual) const {
    const T qf[3] = {T(q_f.x()), T(q_f.y()), T(q_f.z())};
    const T mf[3] = {T(m_f.x()), T(m_f.y()), T(m_f.z())};
    T m[3], c[3];
    ceres::AngleAxisRotatePoint(d_cl, mf, m);
    ceres::AngleAxisRotatePoint(d_cl, qf, c);
    T mc = T(0);
    for (int i = 0; i < 3; ++i) mc += m[i] * (c[i] + T(t_cl[i]) + d_cl[3 + i]);
    const T gain = ceres::exp(ab[0]);
    for (int k = 0; k < kPatternSize; ++k) {
      const Eigen::Vector3d& r = rays[k];
      const T mr = m[0] * r.x() + m[1] * r.y() + m[2] * r.z();
      if (ceres::abs(mr) < T(1e-9)) return false;
      const T lambda = mc / mr;
      if (lambda < T(0.5)) return false;
      T x[3], y[3];
      for (int i = 0; i < 3; ++i)
        x[i] = lambda * (R_rl(i, 0) * r.x() + R_rl(i, 1) * r.y() + R_rl(i, 2) * r.z());
      ceres::AngleAxisRotatePoint(d_rl, x, y);
      for (int i = 0; i < 3; ++i) y[i] += T(t_rl[i]) + d_rl[3 + i];
      if (y[2] < T(0.1)) return false;
      const Eigen::Matrix<T, 2, 1> px = projectPinhole(T(fx), T(fy), T(cx), T(cy), y);
      T value;
      right->Evaluate(px.y(), px.x(), &value);
      residual[k] = T(sqrt_w) * (value - ab[1] - gain * T(left[k]));
    }
    return true;
  }
};

}  // namespace tescalib
