#include "tescalib/core/eval/overlay.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace tescalib {

int drawLidarOverlay(const LidarScan& scan, const Eigen::Isometry3d& T, const CameraIntrinsics& cam,
                     cv::Mat* image, double max_depth) {
  cv::Mat lut(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) lut.at<uint8_t>(i) = static_cast<uint8_t>(i);
  cv::Mat colors;
  cv::applyColorMap(lut, colors, cv::COLORMAP_JET);
  int drawn = 0;
  // A NaN point, transform or depth limit would pass the comparisons below (NaN compares false)
  // and index the colour map with INT_MIN.
  if (!(max_depth > 0) || !std::isfinite(max_depth) || !T.matrix().allFinite()) return 0;
  for (const auto& p : scan) {
    const Eigen::Vector3d c = T * Eigen::Vector3d(p.x, p.y, p.z);
    if (!c.allFinite() || c.z() < 1.0 || c.z() > max_depth) continue;
    const Eigen::Vector2d px = cam.project(c);
    const double uf = px.x(), vf = px.y();
    if (!(uf > -1.0 && vf > -1.0 && uf < image->cols && vf < image->rows)) continue;
    const int u = static_cast<int>(std::lround(uf));
    const int v = static_cast<int>(std::lround(vf));
    if (u < 0 || v < 0 || u >= image->cols || v >= image->rows) continue;
    const int k = 255 - std::min(255, static_cast<int>(255.0 * c.z() / max_depth));
    cv::circle(*image, {u, v}, 1, cv::Scalar(colors.at<cv::Vec3b>(0, k)), cv::FILLED);
    ++drawn;
  }
  return drawn;
}

void drawStatusText(const std::vector<std::string>& lines, cv::Mat* image) {
  if (lines.empty() || image->empty()) return;
  const int font = cv::FONT_HERSHEY_SIMPLEX, line_h = 18;
  const double scale = 0.5;
  const int h = std::min(image->rows, line_h * static_cast<int>(lines.size()) + 6);
  cv::Mat band = (*image)(cv::Rect(0, 0, image->cols, h));
  band *= 0.35;
  for (size_t i = 0; i < lines.size(); ++i)
    cv::putText(*image, lines[i], cv::Point(6, line_h * static_cast<int>(i + 1)), font, scale,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

}  // namespace tescalib
