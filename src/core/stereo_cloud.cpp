#include "tescalib/core/stereo_cloud.h"

#include <chrono>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/error.h"

namespace tescalib {

namespace {
double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
cv::Mat toCv(const Eigen::Matrix3d& M) {
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = M(r, c);
  return m;
}
}  // namespace

bool isRectified(const Eigen::Isometry3d& T, double tol) {
  return (T.linear() - Eigen::Matrix3d::Identity()).norm() < tol &&
         std::fabs(T.translation().y()) < tol && std::fabs(T.translation().z()) < tol &&
         T.translation().x() < 0;
}

bool StereoCloud::disparityAt(double u, double v, double* d) const {
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= disparity.cols || v0 + 1 >= disparity.rows) return false;
  const float* r0 = disparity.ptr<float>(v0);
  const float* r1 = disparity.ptr<float>(v0 + 1);
  const float a = r0[u0], b = r0[u0 + 1], c = r1[u0], e = r1[u0 + 1];
  if (std::isnan(a) || std::isnan(b) || std::isnan(c) || std::isnan(e)) return false;
  const double fu = u - u0, fv = v - v0;
  *d = (1 - fv) * ((1 - fu) * a + fu * b) + fv * ((1 - fu) * c + fu * e);
  return true;
}

Eigen::Vector3d StereoCloud::pointAt(double u, double v, double d) const {
  const double Z = fx * baseline / d;
  const Eigen::Vector3d p_rect((u - cx) / fx * Z, (v - cy) / fy * Z, Z);
  return R_rect_left.transpose() * p_rect;
}

StereoCloud computeStereoCloud(const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                               const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                               const StereoSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  if (left_bgr.empty() || right_bgr.empty() || left_bgr.size() != right_bgr.size())
    throw DataError("stereo pair: images are empty or of different sizes");
  StereoCloud out;
  cv::Mat left, right;
  cv::cvtColor(left_bgr, left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, right, cv::COLOR_BGR2GRAY);
  if (isRectified(T_right_left)) {
    out.fx = rig.left.fx, out.fy = rig.left.fy, out.cx = rig.left.cx, out.cy = rig.left.cy;
    out.baseline = -T_right_left.translation().x();
    // The right camera of a rectified pair may have its own principal point: shift the right
    // image so that both share the left's (KITTI's P2/P3 share cx, cy).
    if (std::fabs(rig.right.cx - rig.left.cx) > 1e-6 ||
        std::fabs(rig.right.cy - rig.left.cy) > 1e-6) {
      const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, rig.left.cx - rig.right.cx, 0, 1,
                             rig.left.cy - rig.right.cy);
      cv::warpAffine(right, right, shift, right.size(), cv::INTER_LINEAR);
    }
  } else {
    // Re-rectify with the current estimate: the right camera is at R, t relative to the left.
    cv::Mat R1, R2, P1, P2, Q;
    const cv::Mat K1 = toCv(rig.left.K()), K2 = toCv(rig.right.K());
    const cv::Mat R = toCv(T_right_left.linear());
    const cv::Mat t = (cv::Mat_<double>(3, 1) << T_right_left.translation().x(),
                       T_right_left.translation().y(), T_right_left.translation().z());
    cv::stereoRectify(K1, cv::Mat(), K2, cv::Mat(), left.size(), R, t, R1, R2, P1, P2, Q,
                      cv::CALIB_ZERO_DISPARITY, 0.0);
    cv::Mat m1x, m1y, m2x, m2y;
    cv::initUndistortRectifyMap(K1, cv::Mat(), R1, P1, left.size(), CV_32FC1, m1x, m1y);
    cv::initUndistortRectifyMap(K2, cv::Mat(), R2, P2, left.size(), CV_32FC1, m2x, m2y);
    cv::Mat lr, rr;
    cv::remap(left, lr, m1x, m1y, cv::INTER_LINEAR);
    cv::remap(right, rr, m2x, m2y, cv::INTER_LINEAR);
    left = lr, right = rr;
    out.fx = P1.at<double>(0, 0), out.fy = P1.at<double>(1, 1);
    out.cx = P1.at<double>(0, 2), out.cy = P1.at<double>(1, 2);
    out.baseline = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out.R_rect_left(r, c) = R1.at<double>(r, c);
  }
  if (out.baseline <= 0) throw DataError("stereo pair: the left->right estimate has no baseline");

  const auto t_sgbm = std::chrono::steady_clock::now();
  const int bs = s.block_size;
  auto sgbm = cv::StereoSGBM::create(
      0, s.num_disparities, bs, 8 * bs * bs, 32 * bs * bs, s.disp12_max_diff, 0, s.uniqueness_ratio,
      s.speckle_window, s.speckle_range,
      s.three_way ? cv::StereoSGBM::MODE_SGBM_3WAY : cv::StereoSGBM::MODE_SGBM);
  cv::Mat disp16;
  sgbm->compute(left, right, disp16);
  out.seconds_sgbm = secondsSince(t_sgbm);

  // Disparity in px, NaN where invalid. SGBM leaves the first num_disparities columns unmatched.
  cv::Mat disp(disp16.size(), CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float min_d = static_cast<float>(out.fx * out.baseline / (s.max_depth * 1.5));
  for (int v = 0; v < disp16.rows; ++v) {
    const int16_t* in = disp16.ptr<int16_t>(v);
    float* o = disp.ptr<float>(v);
    for (int u = 0; u < disp16.cols; ++u) {
      const float d = in[u] / 16.f;
      o[u] = (in[u] <= 0 || d < min_d || u < s.num_disparities) ? nan : d;
    }
  }
  // Edges: on a plane the disparity is affine in (u, v), so a large second difference marks a
  // depth discontinuity; SGBM fattens foreground there, so pixels near it are dropped.
  cv::Mat edge(disp.size(), CV_8U, cv::Scalar(0));
  const int k = s.normal_scale;
  for (int v = k; v < disp.rows - k; ++v) {
    for (int u = k; u < disp.cols - k; ++u) {
      const float d = disp.at<float>(v, u);
      if (std::isnan(d)) continue;
      const float l = disp.at<float>(v, u - k), r = disp.at<float>(v, u + k);
      const float t = disp.at<float>(v - k, u), b = disp.at<float>(v + k, u);
      if (std::isnan(l) || std::isnan(r) || std::isnan(t) || std::isnan(b) ||
          std::fabs(l + r - 2 * d) > s.max_second_diff ||
          std::fabs(t + b - 2 * d) > s.max_second_diff)
        edge.at<uint8_t>(v, u) = 255;
    }
  }
  const int e = s.edge_dilation;
  cv::dilate(edge, edge, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * e + 1, 2 * e + 1)));
  disp.setTo(nan, edge);
  refineDisparity(left, right, &disp, s.refinement);
  out.disparity = disp;

  for (int v = k; v < disp.rows - k; v += s.sample_step) {
    for (int u = k; u < disp.cols - k; u += s.sample_step) {
      const float d = disp.at<float>(v, u);
      if (std::isnan(d)) continue;
      const float l = disp.at<float>(v, u - k), r = disp.at<float>(v, u + k);
      const float t = disp.at<float>(v - k, u), b = disp.at<float>(v + k, u);
      if (std::isnan(l) || std::isnan(r) || std::isnan(t) || std::isnan(b)) continue;
      const double Z = out.fx * out.baseline / d;
      if (Z < s.min_depth || Z > s.max_depth) continue;
      // Plane through the disparity's local affine fit: d = a u + b v + c  =>  n ~ K^T (a, b, c').
      const double a = (r - l) / (2.0 * k), bb = (b - t) / (2.0 * k);
      const double c0 = d - a * (u - out.cx) - bb * (v - out.cy);
      Eigen::Vector3d n(a * out.fx, bb * out.fy, c0);
      Eigen::Vector3d p_rect((u - out.cx) / out.fx * Z, (v - out.cy) / out.fy * Z, Z);
      n.normalize();
      if (n.dot(p_rect) > 0) n = -n;
      StereoPoint sp;
      sp.p = (out.R_rect_left.transpose() * p_rect).cast<float>();
      sp.n = (out.R_rect_left.transpose() * n).cast<float>();
      sp.disparity = d;
      out.points.push_back(sp);
    }
  }
  out.seconds_total = secondsSince(t0);
  return out;
}

}  // namespace tescalib
