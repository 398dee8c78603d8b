#include "tescalib/core/validation/photometric_consistency.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"

namespace tescalib {
namespace {

/// Least-squares gain and offset of right ~ gain * left + offset over the pairs `use` keeps.
void fitAffine(const std::vector<double>& l, const std::vector<double>& r,
               const std::vector<char>& use, double* gain, double* offset) {
  double n = 0, sl = 0, sr = 0, sll = 0, slr = 0;
  for (size_t i = 0; i < l.size(); ++i) {
    if (!use[i]) continue;
    n += 1, sl += l[i], sr += r[i], sll += l[i] * l[i], slr += l[i] * r[i];
  }
  const double var = n * sll - sl * sl;
  if (n < 2 || var <= 1e-9 * n * n) {
    *gain = 1;
    *offset = n > 0 ? (sr - sl) / n : 0;
    return;
  }
  *gain = (n * slr - sl * sr) / var;
  *offset = (sr - *gain * sl) / n;
}

}  // namespace

cv::Mat photometricImage(const cv::Mat& bgr, const PhotometricConsistencySettings& s) {
  cv::Mat g;
  grey(bgr).convertTo(g, CV_64F);
  cv::GaussianBlur(g, g, cv::Size(0, 0), s.blur_sigma_px);
  return g;
}

PhotometricConsistency photometricConsistency(const LidarScan& scan, const cv::Mat& left,
                                              const cv::Mat& right, const StereoRig& rig,
                                              const Eigen::Isometry3d& T_cam_lidar,
                                              const Eigen::Isometry3d& T_right_left,
                                              const PhotometricConsistencySettings& s) {
  PhotometricConsistency out;
  const Eigen::Isometry3d T_right_lidar = T_right_left * T_cam_lidar;
  const size_t stride = std::max<size_t>(1, scan.size() / std::max(1, s.max_points));
  std::vector<double> l, r;
  for (size_t i = 0; i < scan.size(); i += stride) {
    const Eigen::Vector3d p(scan[i].x, scan[i].y, scan[i].z);
    const Eigen::Vector3d cl = T_cam_lidar * p;
    if (!(cl.z() >= s.min_depth_m && cl.z() <= s.max_depth_m)) continue;
    const Eigen::Vector3d cr = T_right_lidar * p;
    if (cr.z() < 0.5) continue;
    const Eigen::Vector2d pl = rig.left.project(cl), pr = rig.right.project(cr);
    const double vl = bilinear(left, pl.x(), pl.y()), vr = bilinear(right, pr.x(), pr.y());
    if (!std::isfinite(vl) || !std::isfinite(vr)) continue;
    l.push_back(vl);
    r.push_back(vr);
  }
  if (l.size() < 10) return out;
  std::vector<char> use(l.size(), 1);
  fitAffine(l, r, use, &out.gain, &out.offset);
  for (size_t i = 0; i < l.size(); ++i)
    use[i] = std::fabs(r[i] - out.gain * l[i] - out.offset) < s.truncate_grey;
  fitAffine(l, r, use, &out.gain, &out.offset);
  double sum = 0;
  for (size_t i = 0; i < l.size(); ++i)
    sum += std::min(std::fabs(r[i] - out.gain * l[i] - out.offset), s.truncate_grey);
  out.points = static_cast<int>(l.size());
  out.residual = sum / l.size();
  return out;
}

}  // namespace tescalib
