#include "tescalib/core/eval/lidar_stereo_agreement.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/common/statistics.h"

namespace tescalib {

DisparityAgreement lidarDisparityAgreement(const LidarScan& scan, const cv::Mat& left_bgr,
                                           const cv::Mat& right_bgr, const StereoRig& rig,
                                           const Eigen::Isometry3d& T_cam_lidar, int max_shift) {
  if (left_bgr.size() != right_bgr.size() || left_bgr.depth() != CV_8U ||
      right_bgr.depth() != CV_8U)
    throw DataError("lidarDisparityAgreement: the pair must be two 8-bit images of one size (" +
                    std::to_string(left_bgr.cols) + "x" + std::to_string(left_bgr.rows) + " and " +
                    std::to_string(right_bgr.cols) + "x" + std::to_string(right_bgr.rows) + ")");
  const cv::Mat gl = grey(left_bgr), gr = grey(right_bgr);
  const int r = 2;  // 5x5 patch
  const double fb = rig.left.fx * rig.baseline();
  const int nshift = 2 * max_shift + 1;
  std::vector<double> global(nshift, 0.0);
  std::vector<double> best_shifts;
  for (const auto& p : scan) {
    const Eigen::Vector3d c = T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
    if (c.z() < 2.0) continue;
    const Eigen::Vector2d px = rig.left.project(c);
    const int u = static_cast<int>(std::lround(px.x()));
    const int v = static_cast<int>(std::lround(px.y()));
    const int d = static_cast<int>(std::lround(fb / c.z()));
    // The left patch and the gradient's neighbours, and every right patch searched (a disparity
    // under max_shift searches to the right of u, beyond the image's last column near its edge).
    if (v - r < 0 || v + r >= gl.rows || u - r < 1 || u + r + 1 >= gl.cols ||
        u - d - max_shift - r < 0 || u - d + max_shift + r >= gr.cols)
      continue;
    const int gx = std::abs(int(gl.at<uint8_t>(v, u + 1)) - int(gl.at<uint8_t>(v, u - 1)));
    if (gx < 12) continue;  // horizontal texture is what disparity can be measured on
    double best = 1e18;
    int best_s = 0;
    std::vector<double> cost(nshift);
    for (int s = -max_shift; s <= max_shift; ++s) {
      double sad = 0;
      for (int dv = -r; dv <= r; ++dv)
        for (int du = -r; du <= r; ++du)
          sad += std::abs(int(gl.at<uint8_t>(v + dv, u + du)) -
                          int(gr.at<uint8_t>(v + dv, u - d - s + du)));
      cost[s + max_shift] = sad;
      if (sad < best) best = sad, best_s = s;
    }
    for (int k = 0; k < nshift; ++k) global[k] += cost[k];
    best_shifts.push_back(best_s);
  }
  DisparityAgreement out;
  out.points = static_cast<int>(best_shifts.size());
  if (best_shifts.empty()) return out;
  out.median_shift = medianOf(best_shifts);
  out.fraction_within_1px = double(std::count_if(best_shifts.begin(), best_shifts.end(),
                                                 [](double s) { return std::fabs(s) <= 1.0; })) /
                            double(best_shifts.size());
  out.best_global_shift =
      int(std::min_element(global.begin(), global.end()) - global.begin()) - max_shift;
  return out;
}

std::vector<DisparitySample> disparitySamples(const LidarScan& scan, const StereoCloud& cloud,
                                              const Eigen::Isometry3d& T_cam_lidar) {
  std::vector<DisparitySample> out;
  if (cloud.disparity.empty() || cloud.baseline <= 0) return out;
  const Eigen::Isometry3d T = Eigen::Isometry3d(cloud.R_rect_left) * T_cam_lidar;
  const double* edges = DisparityResidual::kBinEdges;
  for (const LidarPoint& p : scan) {
    const Eigen::Vector3d r = T * Eigen::Vector3d(p.x, p.y, p.z);
    if (!(r.z() >= edges[0] && r.z() < edges[DisparityResidual::kBins])) continue;
    double d = 0;
    const Eigen::Vector2d px = projectPinhole(cloud.fx, cloud.fy, cloud.cx, cloud.cy, r);
    if (!cloud.disparityAt(px.x(), px.y(), &d)) continue;
    DisparitySample s;
    s.depth_m = r.z();
    s.lidar_px = cloud.fx * cloud.baseline / r.z();
    s.difference_px = d - s.lidar_px;
    s.column_fraction = px.x() / cloud.disparity.cols;
    s.ring = p.ring;
    out.push_back(s);
  }
  return out;
}

DisparityResidual disparityResidualOf(const std::vector<DisparitySample>& samples) {
  DisparityResidual out;
  std::vector<double> all;
  std::array<std::vector<double>, DisparityResidual::kBins> bins;
  const double* edges = DisparityResidual::kBinEdges;
  for (const DisparitySample& s : samples) {
    const double diff = s.difference_px;
    ++out.points_with_disparity;
    out.mean_truncated_abs_px += std::min(std::fabs(diff), DisparityResidual::kMaxDifferencePx);
    if (std::fabs(diff) > DisparityResidual::kMaxDifferencePx) continue;
    all.push_back(diff);
    int b = 0;
    while (b + 1 < DisparityResidual::kBins && s.depth_m >= edges[b + 1]) ++b;
    bins[b].push_back(diff);
  }
  out.points = static_cast<int>(all.size());
  if (out.points_with_disparity > 0) out.mean_truncated_abs_px /= out.points_with_disparity;
  out.median_px = medianOf(all);
  for (int b = 0; b < DisparityResidual::kBins; ++b) {
    out.bin_points[b] = static_cast<int>(bins[b].size());
    out.bin_median_px[b] = medianOf(bins[b]);
  }
  return out;
}

DisparityResidual lidarDisparityResidual(const LidarScan& scan, const StereoCloud& cloud,
                                         const Eigen::Isometry3d& T_cam_lidar) {
  return disparityResidualOf(disparitySamples(scan, cloud, T_cam_lidar));
}

}  // namespace tescalib
