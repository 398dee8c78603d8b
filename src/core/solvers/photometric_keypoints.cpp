// Key point selection of the left-right calibration (paper, "Left and right camera calibration"):
// per cell the strongest gradient of the left image that has LiDAR depth.
#include <opencv2/imgproc.hpp>

#include "tescalib/core/solvers/photometric_solver.h"

namespace tescalib {

std::vector<KeyPoint> selectKeyPoints(const Keyframe& kf, const MeshDepth& md,
                                      const PhotometricSettings& s) {
  cv::Mat gx, gy;
  cv::Scharr(kf.left_gray, gx, CV_32F, 1, 0, 1.0 / 32);
  cv::Scharr(kf.left_gray, gy, CV_32F, 0, 1, 1.0 / 32);
  // Local depth range (+inf where a face is missing nearby, so such pixels are rejected too).
  cv::Mat zmin, zmax;
  const int r = s.smooth_depth_radius_px;
  if (r > 0) {
    const cv::Mat box = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1));
    cv::erode(md.depth, zmin, box);
    cv::dilate(md.depth, zmax, box);
  }
  std::vector<KeyPoint> out;
  const int c = s.cell_size, border = 8;
  for (int v0 = border; v0 + c <= kf.left_gray.rows - border; v0 += c) {
    for (int u0 = border; u0 + c <= kf.left_gray.cols - border; u0 += c) {
      KeyPoint best;
      for (int v = v0; v < v0 + c; ++v)
        for (int u = u0; u < u0 + c; ++u) {
          const double g2 = double(gx.at<float>(v, u)) * gx.at<float>(v, u) +
                            double(gy.at<float>(v, u)) * gy.at<float>(v, u);
          const int f = md.face_id.at<int>(v, u);
          const float z = md.depth.at<float>(v, u);
          if (f < 0 || z < s.min_depth || z > s.max_depth || g2 <= best.grad2) continue;
          const bool smooth =
              r == 0 || zmax.at<float>(v, u) - zmin.at<float>(v, u) <= s.smooth_depth_tolerance * z;
          if (!smooth) continue;
          best = {double(u), double(v), f, g2};
        }
      if (best.face >= 0 && best.grad2 > s.min_gradient * s.min_gradient) out.push_back(best);
    }
  }
  if (static_cast<int>(out.size()) > s.max_keypoints_per_keyframe) {
    std::vector<KeyPoint> kept;
    // Evenly over the list, exactly max_keypoints_per_keyframe of them (an accumulated
    // floating-point step would keep one more now and then).
    const size_t n = out.size(), m = static_cast<size_t>(s.max_keypoints_per_keyframe);
    kept.reserve(m);
    for (size_t k = 0; k < m; ++k) kept.push_back(out[k * n / m]);
    out.swap(kept);
  }
  return out;
}

}  // namespace tescalib
