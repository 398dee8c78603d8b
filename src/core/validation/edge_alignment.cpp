#include "tescalib/core/validation/edge_alignment.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/lidar/range_image.h"

namespace tescalib {
namespace {

/// The q-quantile of the map's values (every 4th pixel of every 4th row).
double quantileOf(const cv::Mat& m, double q) {
  std::vector<float> v;
  for (int r = 0; r < m.rows; r += 4)
    for (int c = 0; c < m.cols; c += 4) v.push_back(m.at<float>(r, c));
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

double rangeOf(const LidarPoint& p) { return std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z); }

}  // namespace

cv::Mat edgeStrengthMap(const cv::Mat& bgr, const EdgeAlignmentSettings& s) {
  cv::Mat g;
  grey(bgr).convertTo(g, CV_32F);
  cv::GaussianBlur(g, g, cv::Size(0, 0), s.blur_sigma_px);
  cv::Mat dx, dy, mag;
  cv::Sobel(g, dx, CV_32F, 1, 0);
  cv::Sobel(g, dy, CV_32F, 0, 1);
  cv::magnitude(dx, dy, mag);
  const double scale = quantileOf(mag, 0.98);
  if (scale > 0) mag /= scale;
  cv::min(mag, 1.0, mag);
  cv::Mat spread = mag.clone(), dilated;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  for (int k = 0; k < s.spread_px; ++k) {
    cv::dilate(spread, dilated, kernel);
    spread = cv::max(spread, dilated * s.spread_decay);
  }
  cv::Mat out;
  cv::Mat(s.edge_weight * mag + (1.0 - s.edge_weight) * spread).convertTo(out, CV_64F);
  return out;
}

std::vector<EdgePoint> depthDiscontinuities(const LidarScan& scan, const EdgeAlignmentSettings& s) {
  std::vector<EdgePoint> out;
  int rings = 0;
  for (const auto& p : scan) rings = std::max(rings, p.ring + 1);
  if (rings == 0) return out;
  const RangeImage ri = buildRangeImage(scan, rings, 4096, s.min_range_m, s.max_range_m);
  for (int r = 0; r < ri.rings; ++r)
    for (int c = 0; c < ri.cols; ++c) {
      const int i = ri.at(r, c);
      if (i < 0) continue;
      const double range = rangeOf(scan[i]);
      double jump = 0;
      for (int dc : {-1, 1}) {
        const int j = ri.at(r, c + dc);
        if (j >= 0) jump = std::max(jump, rangeOf(scan[j]) - range);
      }
      if (jump < s.min_jump_m || jump < s.min_jump_fraction * range) continue;
      const LidarPoint& p = scan[i];
      out.push_back({Eigen::Vector3d(p.x, p.y, p.z), std::sqrt(std::min(jump, s.max_jump_m))});
    }
  return out;
}

double edgeAlignment(const std::vector<EdgePoint>& points, const cv::Mat& edge_map,
                     const CameraIntrinsics& cam, const Eigen::Isometry3d& T_cam_lidar,
                     int* points_inside) {
  double sum = 0, weights = 0;
  int inside = 0;
  for (const EdgePoint& e : points) {
    const Eigen::Vector3d c = T_cam_lidar * e.p;
    if (c.z() < 1.0) continue;
    const Eigen::Vector2d px = cam.project(c);
    const double v = bilinear(edge_map, px.x(), px.y());
    if (!std::isfinite(v)) continue;
    sum += e.weight * v;
    weights += e.weight;
    ++inside;
  }
  if (points_inside) *points_inside = inside;
  return weights > 0 ? sum / weights : 0.0;
}

}  // namespace tescalib
