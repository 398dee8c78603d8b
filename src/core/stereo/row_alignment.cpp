#include "tescalib/core/stereo/row_alignment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/statistics.h"

namespace tescalib {

VerticalAlignment verticalAlignment(const cv::Mat& left, const cv::Mat& right,
                                    const StereoCloud& cloud, const StereoRig& rig,
                                    const Eigen::Isometry3d& T_right_left, int max_corners) {
  VerticalAlignment out;
  if (left.empty() || left.size() != right.size() || cloud.disparity.empty()) return out;
  const cv::Mat gl = grey(left), gr = grey(right);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gl, corners, max_corners, 0.005, 5);
  const Eigen::Matrix3d K_inv = rig.left.K().inverse();
  const Eigen::Matrix3d K_rect =
      (Eigen::Matrix3d() << cloud.fx, 0, cloud.cx, 0, cloud.fy, cloud.cy, 0, 0, 1).finished();
  std::vector<cv::Point2f> from, to;
  for (const cv::Point2f& c : corners) {
    // The corner in the cloud's rectification, its disparity there, its point, the right camera.
    const Eigen::Vector3d r = K_rect * cloud.R_rect_left * K_inv * Eigen::Vector3d(c.x, c.y, 1);
    double d = 0;
    if (r.z() <= 0 || !cloud.disparityAt(r.x() / r.z(), r.y() / r.z(), &d) || d <= 0) continue;
    const Eigen::Vector3d X_r = T_right_left * cloud.pointAt(r.x() / r.z(), r.y() / r.z(), d);
    if (X_r.z() <= 0) continue;
    const Eigen::Vector3d q = rig.right.K() * (X_r / X_r.z());
    from.push_back(c);
    to.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
  }
  if (from.empty()) return out;
  const std::vector<cv::Point2f> start = to;
  std::vector<uchar> found;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(
      gl, gr, from, to, found, err, cv::Size(15, 15), 0,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-4),
      cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<Eigen::Vector3d> J;
  std::vector<double> dv;
  for (size_t i = 0; i < from.size(); ++i) {
    const double dy = to[i].y - start[i].y;
    // A match that left the row or its disparity by pixels is a wrong one, not misalignment.
    if (!found[i] || std::fabs(dy) > 2.0 || std::fabs(to[i].x - start[i].x) > 2.0) continue;
    const Eigen::Vector3d ray = rig.left.ray(from[i].x, from[i].y);
    J.emplace_back(1.0, ray.x(), ray.y());
    dv.push_back(dy);
  }
  out.points = static_cast<int>(dv.size());
  if (out.points < 10) {
    // Too few to fit: no figure, rather than zeros that read as a perfectly aligned pair.
    out.median_px = out.offset_px = out.slope_x_px = out.slope_y_px = out.spread_px =
        std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  out.median_px = medianOf(dv);
  // Affine fit, iteratively reweighted with a Huber weight (0.2 px).
  Eigen::Vector3d c(out.median_px, 0, 0);
  for (int it = 0; it < 10; ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < dv.size(); ++i) {
      const double e = dv[i] - J[i].dot(c);
      const double w = std::fabs(e) < 0.2 ? 1.0 : 0.2 / std::fabs(e);
      H += w * J[i] * J[i].transpose();
      g += w * J[i] * e;
    }
    c += H.ldlt().solve(g);
  }
  std::vector<double> res(dv.size());
  for (size_t i = 0; i < dv.size(); ++i) res[i] = std::fabs(dv[i] - J[i].dot(c));
  out.offset_px = c[0];
  out.slope_x_px = c[1];
  out.slope_y_px = c[2];
  out.spread_px = 1.4826 * medianOf(res);
  return out;
}

Eigen::Isometry3d rowAlignedExtrinsic(const Eigen::Isometry3d& T_right_left,
                                      const VerticalAlignment& rows, double fy) {
  if (!std::isfinite(rows.offset_px) || !std::isfinite(rows.slope_x_px) || !(fy > 0))
    return T_right_left;
  // A right camera turned by Rx(a) sees a point's row f a lower (y' = y - a z); by Rz(g), f g x
  // higher at normalised x (y' = y + g x).
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = expSO3(Eigen::Vector3d(-rows.offset_px / fy, 0.0, rows.slope_x_px / fy));
  return turn * T_right_left;
}

double largestRowCorrectionPx(const VerticalAlignment& rows, const CameraIntrinsics& left) {
  const double x_max = std::max(left.cx, left.width - left.cx) / left.fx;
  return std::fabs(rows.offset_px) + std::fabs(rows.slope_x_px) * x_max;
}

}  // namespace tescalib
