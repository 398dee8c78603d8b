#include "tescalib/core/stereo/stereo_surface_normal.h"

#include <cmath>

#include <Eigen/Cholesky>

namespace tescalib {

bool stereoSurfaceNormal(const StereoCloud& cloud, double u, double v, int h,
                         Eigen::Vector3d* normal) {
  if (h < 1 || cloud.disparity.empty() || !std::isfinite(u) || !std::isfinite(v)) return false;
  // Tent weights, 0 at h + 1 px from (u, v): the fit changes continuously as (u, v) moves (a
  // pixel enters or leaves the patch with weight 0), so re-associations do not jump.
  const double reach = h + 1.0;
  const int i0 = static_cast<int>(std::floor(u - reach)) + 1,
            j0 = static_cast<int>(std::floor(v - reach)) + 1;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double valid = 0, all = 0;
  for (int j = j0; j < v + reach; ++j) {
    const double wv = 1 - std::fabs(j - v) / reach;
    const bool row_in = j >= 0 && j < cloud.disparity.rows;
    for (int i = i0; i < u + reach; ++i) {
      const double w = wv * (1 - std::fabs(i - u) / reach);
      all += w;
      if (!row_in || i < 0 || i >= cloud.disparity.cols) continue;
      const double d = cloud.disparity.ptr<float>(j)[i];
      if (!std::isfinite(d) || d <= 0) continue;
      const Eigen::Vector3d x(i - u, j - v, 1.0);
      A.noalias() += w * x * x.transpose();
      b += w * d * x;
      valid += w;
    }
  }
  if (!(valid >= 0.6 * all)) return false;
  const Eigen::Vector3d fit = A.ldlt().solve(b);  // a, b, d0
  // In the rectified frame a plane n . X = n0 has the disparity f B (n . X) / (n0 Z), affine in
  // the pixel: d = (f B / n0) (n_x (u - cx) / fx + n_y (v - cy) / fy + n_z). Matching the fit's
  // coefficients gives n up to scale.
  const double a = fit[0], c = fit[1], d0 = fit[2];
  const Eigen::Vector3d n_rect(a * cloud.fx, c * cloud.fy,
                               d0 + a * (cloud.cx - u) + c * (cloud.cy - v));
  if (!(n_rect.norm() > 0) || !n_rect.allFinite()) return false;
  *normal = (cloud.R_rect_left.transpose() * n_rect).normalized();
  return true;
}

}  // namespace tescalib
