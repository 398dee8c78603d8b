#include "tescalib/core/stereo/stereo_cloud.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/stereo/sgbm_matching.h"

namespace tescalib {

namespace {
cv::Mat toCv(const Eigen::Matrix3d& M) {
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = M(r, c);
  return m;
}

/// The rectification of the pair for a left->right estimate: shared intrinsics of both rectified
/// images, the rotations from each original camera into its rectified frame, the baseline.
struct Rectification {
  double fx = 0, fy = 0, cx = 0, cy = 0, baseline = 0;
  Eigen::Matrix3d R_left = Eigen::Matrix3d::Identity(), R_right = Eigen::Matrix3d::Identity();
  bool identity = true;  ///< the input pair is already rectified (right image only shifted)
  cv::Mat K1, K2, R1, R2, P1, P2;  ///< OpenCV's, when not `identity`
};

Rectification rectificationFor(const StereoRig& rig, const Eigen::Isometry3d& T, cv::Size size) {
  Rectification r;
  // Rectified as delivered only with one focal length for both cameras: the identity path
  // shifts the right image to the left's principal point but does not scale it.
  const bool same_focal = std::fabs(rig.right.fx - rig.left.fx) <= 1e-9 * rig.left.fx &&
                          std::fabs(rig.right.fy - rig.left.fy) <= 1e-9 * rig.left.fy;
  if (isRectified(T) && same_focal) {
    r.fx = rig.left.fx, r.fy = rig.left.fy, r.cx = rig.left.cx, r.cy = rig.left.cy;
    r.baseline = -T.translation().x();
    return r;
  }
  // Re-rectify with the current estimate: the right camera is at R, t relative to the left.
  r.K1 = toCv(rig.left.K()), r.K2 = toCv(rig.right.K());
  const cv::Mat R = toCv(T.linear());
  const cv::Mat t =
      (cv::Mat_<double>(3, 1) << T.translation().x(), T.translation().y(), T.translation().z());
  cv::Mat Q;
  cv::stereoRectify(r.K1, cv::Mat(), r.K2, cv::Mat(), size, R, t, r.R1, r.R2, r.P1, r.P2, Q,
                    cv::CALIB_ZERO_DISPARITY, 0.0);
  r.identity = false;
  r.fx = r.P1.at<double>(0, 0), r.fy = r.P1.at<double>(1, 1);
  r.cx = r.P1.at<double>(0, 2), r.cy = r.P1.at<double>(1, 2);
  r.baseline = -r.P2.at<double>(0, 3) / r.P2.at<double>(0, 0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      r.R_left(i, j) = r.R1.at<double>(i, j);
      r.R_right(i, j) = r.R2.at<double>(i, j);
    }
  return r;
}

}  // namespace

namespace {
/// A DataError when the left->right estimate cannot rectify a pair (stereoExtrinsicProblem).
void requireUsablePair(const Eigen::Isometry3d& T_right_left) {
  const std::string problem = stereoExtrinsicProblem(T_right_left);
  if (!problem.empty()) throw DataError("stereo pair: " + problem);
}
}  // namespace

double rectifiedBaseline(const StereoRig& rig, const Eigen::Isometry3d& T_right_left) {
  if (!isRigidTransform(T_right_left)) return 0.0;
  // A rig read from a calibration file alone has no image size: the principal point's twice.
  const cv::Size size =
      rig.left.width > 0 && rig.left.height > 0
          ? cv::Size(rig.left.width, rig.left.height)
          : cv::Size(static_cast<int>(2 * rig.left.cx) + 1, static_cast<int>(2 * rig.left.cy) + 1);
  return rectificationFor(rig, T_right_left, size).baseline;
}

namespace {

void setRectification(const Rectification& r, StereoCloud* out) {
  out->fx = r.fx, out->fy = r.fy, out->cx = r.cx, out->cy = r.cy;
  out->baseline = r.baseline;
  out->R_rect_left = r.R_left;
  out->R_rect_right = r.R_right;
}

/// Stereo points with normals from the disparity map, one every `sample_step` pixels.
void samplePoints(const StereoSettings& s, StereoCloud* out) {
  const cv::Mat& disp = out->disparity;
  const int k = s.normal_scale;
  for (int v = k; v < disp.rows - k; v += s.sample_step) {
    for (int u = k; u < disp.cols - k; u += s.sample_step) {
      const float d = disp.at<float>(v, u);
      if (std::isnan(d)) continue;
      const float l = disp.at<float>(v, u - k), r = disp.at<float>(v, u + k);
      const float t = disp.at<float>(v - k, u), b = disp.at<float>(v + k, u);
      if (std::isnan(l) || std::isnan(r) || std::isnan(t) || std::isnan(b)) continue;
      const double Z = out->fx * out->baseline / d;
      if (Z < s.min_depth || Z > s.max_depth) continue;
      // Plane through the disparity's local affine fit: d = a u + b v + c  =>  n ~ K^T (a, b, c').
      const double a = (r - l) / (2.0 * k), bb = (b - t) / (2.0 * k);
      const double c0 = d - a * (u - out->cx) - bb * (v - out->cy);
      Eigen::Vector3d n(a * out->fx, bb * out->fy, c0);
      const Eigen::Vector3d p_rect =
          backProjectPinhole<double>(out->fx, out->fy, out->cx, out->cy, u, v, Z);
      n.normalize();
      if (n.dot(p_rect) > 0) n = -n;
      StereoPoint sp;
      sp.p = (out->R_rect_left.transpose() * p_rect).cast<float>();
      sp.n = (out->R_rect_left.transpose() * n).cast<float>();
      sp.disparity = d;
      out->points.push_back(sp);
    }
  }
}
}  // namespace

bool isRectified(const Eigen::Isometry3d& T, double tol) {
  return (T.linear() - Eigen::Matrix3d::Identity()).norm() < tol &&
         std::fabs(T.translation().y()) < tol && std::fabs(T.translation().z()) < tol &&
         T.translation().x() < 0;
}

bool StereoCloud::disparityAt(double u, double v, double* d) const {
  if (!std::isfinite(u) || !std::isfinite(v)) return false;
  // Within 1e-6 px of a pixel is that pixel (a pixel map's round-off must not make it need its
  // neighbour).
  const double us = std::round(u), vs = std::round(v);
  if (std::fabs(u - us) < 1e-6) u = us;
  if (std::fabs(v - vs) < 1e-6) v = vs;
  if (u < 0 || v < 0 || u > disparity.cols - 1 || v > disparity.rows - 1) return false;
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  const double fu = u - u0, fv = v - v0;
  // A neighbour of weight 0 (an integer coordinate) need be neither valid nor inside: a pixel's
  // own disparity is returned exactly, also at a valid region's right and bottom edges.
  const int u1 = fu > 0 ? u0 + 1 : u0, v1 = fv > 0 ? v0 + 1 : v0;
  if (u1 >= disparity.cols || v1 >= disparity.rows) return false;
  const float* r0 = disparity.ptr<float>(v0);
  const float* r1 = disparity.ptr<float>(v1);
  const float a = r0[u0], b = r0[u1], c = r1[u0], e = r1[u1];
  if (std::isnan(a) || std::isnan(b) || std::isnan(c) || std::isnan(e)) return false;
  *d = (1 - fv) * ((1 - fu) * a + fu * b) + fv * ((1 - fu) * c + fu * e);
  return true;
}

Eigen::Vector3d StereoCloud::pointAt(double u, double v, double d) const {
  const double Z = fx * baseline / d;
  const Eigen::Vector3d p_rect = backProjectPinhole(fx, fy, cx, cy, u, v, Z);
  return R_rect_left.transpose() * p_rect;
}

bool matchExposure(cv::Mat* left_grey, cv::Mat* right_grey, double ratio_limit) {
  if (!(ratio_limit > 1) || left_grey->empty() || right_grey->empty()) return false;
  cv::Scalar mean_l, sd_l, mean_r, sd_r;
  cv::meanStdDev(*left_grey, mean_l, sd_l);
  cv::meanStdDev(*right_grey, mean_r, sd_r);
  const auto apart = [ratio_limit](double a, double b) {
    return a <= 0 || b <= 0 || std::max(a / b, b / a) > ratio_limit;
  };
  if (!apart(mean_l[0], mean_r[0]) && !apart(sd_l[0], sd_r[0])) return false;
  if (sd_l[0] <= 0 || sd_r[0] <= 0) return false;  // a flat image has nothing to map
  // Histogram matching: each grey level of the source goes to the target's level at the same
  // quantile (the middle of its bin), so clipped highlights and any monotonic response map too.
  cv::Mat* source = sd_l[0] < sd_r[0] ? left_grey : right_grey;
  const cv::Mat& target = source == left_grey ? *right_grey : *left_grey;
  const auto cdf = [](const cv::Mat& m) {
    std::array<double, 256> c{};
    for (int v = 0; v < m.rows; ++v) {
      const uint8_t* p = m.ptr<uint8_t>(v);
      for (int u = 0; u < m.cols; ++u) c[p[u]] += 1;
    }
    double sum = 0;
    for (double& x : c) x = (sum += x) / m.total();
    return c;
  };
  const std::array<double, 256> cs = cdf(*source), ct = cdf(target);
  cv::Mat lut(1, 256, CV_8U);
  int w = 0;
  for (int v = 0; v < 256; ++v) {
    const double q = 0.5 * ((v ? cs[v - 1] : 0.0) + cs[v]);
    while (w < 255 && ct[w] < q) ++w;
    lut.at<uint8_t>(v) = static_cast<uint8_t>(w);
  }
  cv::Mat mapped;
  cv::LUT(*source, lut, mapped);
  *source = mapped;
  return true;
}

namespace {

/// A DataError when the pair or the settings cannot give a stereo cloud.
void requireUsableInputs(const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                         const StereoSettings& s) {
  if (left_bgr.empty() || right_bgr.empty() || left_bgr.size() != right_bgr.size())
    throw DataError("stereo pair: images are empty or of different sizes");
  if (left_bgr.type() != CV_8UC3 || right_bgr.type() != CV_8UC3)
    throw DataError("stereo pair: images must be 8-bit BGR (CV_8UC3)");
  if (left_bgr.cols <= s.num_disparities + s.block_size)
    throw DataError("stereo pair: images " + std::to_string(left_bgr.cols) +
                    " px wide, not wider than num_disparities + block_size (" +
                    std::to_string(s.num_disparities + s.block_size) + ")");
  if (!validSgbmPaths(s.sgbm_paths))
    throw DataError("stereo settings: sgbm_paths must be 3, 5 or 8 (got " +
                    std::to_string(s.sgbm_paths) + ")");
  if (!(s.rectified_vertical_blur_px >= 0) || !std::isfinite(s.rectified_vertical_blur_px))
    throw DataError(
        "stereo settings: rectified_vertical_blur_px must be a finite value of at least 0");
  if (s.sgbm_both_ways && !(s.both_ways_max_diff_px >= 0))
    throw DataError("stereo settings: both_ways_max_diff_px must be at least 0");
  if (s.num_disparities < 16 || s.num_disparities % 16 || s.sample_step < 1 || s.normal_scale < 1)
    throw DataError(
        "stereo settings: num_disparities must be a positive multiple of 16, sample_step and "
        "normal_scale at least 1");
}

/// Rectifies the grey pair in place with `rect`; a re-rectified pair is then low-pass filtered
/// by `blur_px` (StereoSettings::rectified_vertical_blur_px). Returns the low-pass applied (px;
/// 0: none).
double rectifyPair(const Rectification& rect, const StereoRig& rig, double blur_px, cv::Mat* left,
                   cv::Mat* right) {
  if (rect.identity) {
    // The right camera of a rectified pair may have its own principal point: shift the right
    // image so that both share the left's (KITTI's P2/P3 share cx, cy).
    if (std::fabs(rig.right.cx - rig.left.cx) > 1e-6 ||
        std::fabs(rig.right.cy - rig.left.cy) > 1e-6) {
      const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, rig.left.cx - rig.right.cx, 0, 1,
                             rig.left.cy - rig.right.cy);
      cv::warpAffine(*right, *right, shift, right->size(), cv::INTER_LINEAR);
    }
    return 0.0;
  }
  cv::Mat m1x, m1y, m2x, m2y;
  cv::initUndistortRectifyMap(rect.K1, cv::Mat(), rect.R1, rect.P1, left->size(), CV_32FC1, m1x,
                              m1y);
  cv::initUndistortRectifyMap(rect.K2, cv::Mat(), rect.R2, rect.P2, left->size(), CV_32FC1, m2x,
                              m2y);
  cv::Mat lr, rr;
  cv::remap(*left, lr, m1x, m1y, cv::INTER_LINEAR);
  cv::remap(*right, rr, m2x, m2y, cv::INTER_LINEAR);
  if (blur_px > 0) {  // along the columns alone: the disparity's direction keeps its detail
    cv::GaussianBlur(lr, lr, cv::Size(1, 0), 0.0, blur_px, cv::BORDER_REPLICATE);
    cv::GaussianBlur(rr, rr, cv::Size(1, 0), 0.0, blur_px, cv::BORDER_REPLICATE);
  }
  *left = lr, *right = rr;
  return std::max(blur_px, 0.0);
}

/// Edges: on a plane the disparity is affine in (u, v), so a large second difference marks a
/// depth discontinuity; SGBM fattens foreground there, so pixels near it are dropped.
void dropDepthEdges(const StereoSettings& s, cv::Mat* disparity) {
  const cv::Mat& disp = *disparity;
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
  disparity->setTo(std::numeric_limits<float>::quiet_NaN(), edge);
}

}  // namespace

StereoCloud computeStereoCloud(const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                               const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                               const StereoSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  requireUsableInputs(left_bgr, right_bgr, s);
  requireUsablePair(T_right_left);
  StereoCloud out;
  cv::Mat left, right;
  cv::cvtColor(left_bgr, left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, right, cv::COLOR_BGR2GRAY);
  out.exposure_equalized = matchExposure(&left, &right, s.equalize_exposure_ratio);
  const Rectification rect = rectificationFor(rig, T_right_left, left.size());
  setRectification(rect, &out);
  out.vertical_low_pass_px = rectifyPair(rect, rig, s.rectified_vertical_blur_px, &left, &right);
  if (out.baseline <= 0) throw DataError("stereo pair: the left->right estimate has no baseline");
  const auto t_sgbm = std::chrono::steady_clock::now();
  cv::Mat disp = sgbmDisparity(left, right, s, out.fx * out.baseline / (s.max_depth * 1.5));
  out.seconds_sgbm = secondsSince(t_sgbm);
  dropDepthEdges(s, &disp);
  refineDisparity(left, right, &disp, s.refinement);
  out.disparity = disp;
  samplePoints(s, &out);
  out.seconds_total = secondsSince(t0);
  return out;
}

StereoCloud retriangulateStereoCloud(const StereoCloud& matched, const StereoRig& rig,
                                     const Eigen::Isometry3d& T_right_left,
                                     const StereoSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat& in = matched.disparity;
  if (in.empty()) throw DataError("stereo cloud: no disparity to re-triangulate");
  requireUsablePair(T_right_left);
  StereoCloud out;
  out.exposure_equalized = matched.exposure_equalized;
  out.vertical_low_pass_px = matched.vertical_low_pass_px;
  const Rectification rect = rectificationFor(rig, T_right_left, in.size());
  if (rect.baseline <= 0) throw DataError("stereo pair: the left->right estimate has no baseline");
  setRectification(rect, &out);
  // Each new rectified left pixel: its ray, the matched pixel pair in the old rectification
  // (bilinear disparity), the right pixel's ray, and where that lands in the new rectified right
  // image. Both images' pixels are unchanged, so this is the same match triangulated with the
  // new extrinsic (left and right rays in their own camera frames: R_rect^T K_rect^-1 [u v 1]).
  const Eigen::Matrix3d K_new =
      (Eigen::Matrix3d() << out.fx, 0, out.cx, 0, out.fy, out.cy, 0, 0, 1).finished();
  const Eigen::Matrix3d K_old =
      (Eigen::Matrix3d() << matched.fx, 0, matched.cx, 0, matched.fy, matched.cy, 0, 0, 1)
          .finished();
  // Pixel maps: new rect left -> old rect left, old rect right -> new rect right.
  const Eigen::Matrix3d H_left =
      K_old * matched.R_rect_left * out.R_rect_left.transpose() * K_new.inverse();
  const Eigen::Matrix3d H_right =
      K_new * out.R_rect_right * matched.R_rect_right.transpose() * K_old.inverse();
  cv::Mat disp(in.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  cv::parallel_for_(cv::Range(0, in.rows), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      float* o = disp.ptr<float>(v);
      for (int u = 0; u < in.cols; ++u) {
        const Eigen::Vector3d pl = H_left * Eigen::Vector3d(u, v, 1.0);
        const double uo = pl.x() / pl.z(), vo = pl.y() / pl.z();
        double d;
        if (!matched.disparityAt(uo, vo, &d)) continue;
        const Eigen::Vector3d pr = H_right * Eigen::Vector3d(uo - d, vo, 1.0);
        const double dn = u - pr.x() / pr.z();
        if (dn > 0) o[u] = static_cast<float>(dn);
      }
    }
  });
  out.disparity = disp;
  samplePoints(s, &out);
  out.seconds_total = secondsSince(t0);
  return out;
}

}  // namespace tescalib
