#include "tescalib/core/consistency.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace tescalib {

DisparityAgreement lidarDisparityAgreement(const LidarScan& scan, const cv::Mat& left_bgr,
                                           const cv::Mat& right_bgr, const StereoRig& rig,
                                           const Eigen::Isometry3d& T_cam_lidar, int max_shift) {
  cv::Mat gl, gr;
  cv::cvtColor(left_bgr, gl, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, gr, cv::COLOR_BGR2GRAY);
  const int r = 2;  // 5x5 patch
  const double fb = rig.left.fx * rig.baseline();
  const int nshift = 2 * max_shift + 1;
  std::vector<double> global(nshift, 0.0);
  std::vector<double> best_shifts;
  for (const auto& p : scan) {
    const Eigen::Vector3d c = T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
    if (c.z() < 2.0) continue;
    const int u = static_cast<int>(std::lround(rig.left.fx * c.x() / c.z() + rig.left.cx));
    const int v = static_cast<int>(std::lround(rig.left.fy * c.y() / c.z() + rig.left.cy));
    const int d = static_cast<int>(std::lround(fb / c.z()));
    if (v - r < 0 || v + r >= gl.rows || u + r >= gl.cols || u - d - max_shift - r < 0) continue;
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
  std::vector<double> sorted = best_shifts;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  out.median_shift = sorted[sorted.size() / 2];
  out.fraction_within_1px = double(std::count_if(best_shifts.begin(), best_shifts.end(),
                                                 [](double s) { return std::fabs(s) <= 1.0; })) /
                            double(best_shifts.size());
  out.best_global_shift =
      int(std::min_element(global.begin(), global.end()) - global.begin()) - max_shift;
  return out;
}

}  // namespace tescalib
