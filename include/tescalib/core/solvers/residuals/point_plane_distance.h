// The signed distance shared by both LiDAR-stereo residuals: the LiDAR face centroid and normal
// moved by the pose, against the (scaled) stereo point:
//   dist = n^T (Exp(phi) q + t_ref + tau - scale * p_s),   n = Exp(phi) m
// with q = R_ref p_m and m = R_ref n_m (the reference rotation already applied).
#pragma once

#include <ceres/rotation.h>
#include <Eigen/Core>

namespace tescalib {

/// Returns the distance and writes the rotated normal to `n`. `delta` = [phi; tau].
template <typename T>
T pointPlaneDistance(const T* const delta, const T* const scale, const Eigen::Vector3d& q_ref,
                     const Eigen::Vector3d& m_ref, const Eigen::Vector3d& t_ref,
                     const Eigen::Vector3d& p_s, T n[3]) {
  const T q[3] = {T(q_ref.x()), T(q_ref.y()), T(q_ref.z())};
  const T m[3] = {T(m_ref.x()), T(m_ref.y()), T(m_ref.z())};
  T c[3];
  ceres::AngleAxisRotatePoint(delta, q, c);
  ceres::AngleAxisRotatePoint(delta, m, n);
  T dist = T(0);
  for (int i = 0; i < 3; ++i)
    dist += n[i] * (c[i] + T(t_ref[i]) + delta[3 + i] - scale[0] * T(p_s[i]));
  return dist;
}

/// Scale of a stereo point whose disparity `d` is corrected by a yaw `phi` of the right camera
/// relative to the clouds' rectification: d' = d + g phi with g = f (1 + x_r^2) (x_r: normalised
/// right image coordinate), and the point scales with d / d' (times the stereo scale).
template <typename T>
T correctedStereoScale(const T* const scale, const T* const yaw, double d, double g) {
  T dc = T(d) + T(g) * yaw[0];
  if (dc < T(0.1 * d)) dc = T(0.1 * d);  // far outside the model: keep the point finite
  return scale[0] * T(d) / dc;
}

}  // namespace tescalib
