#include "tescalib/core/consistency.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "tescalib/core/error.h"

namespace tescalib {

namespace {

cv::Mat grey(const cv::Mat& img) {
  if (img.channels() == 1) return img;
  cv::Mat g;
  cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  return g;
}

double medianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

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
    const int u = static_cast<int>(std::lround(rig.left.fx * c.x() / c.z() + rig.left.cx));
    const int v = static_cast<int>(std::lround(rig.left.fy * c.y() / c.z() + rig.left.cy));
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

DisparityResidual lidarDisparityResidual(const LidarScan& scan, const StereoCloud& cloud,
                                         const Eigen::Isometry3d& T_cam_lidar) {
  DisparityResidual out;
  if (cloud.disparity.empty() || cloud.baseline <= 0) return out;
  const Eigen::Isometry3d T = Eigen::Isometry3d(cloud.R_rect_left) * T_cam_lidar;
  std::vector<double> all;
  std::array<std::vector<double>, DisparityResidual::kBins> bins;
  const double* edges = DisparityResidual::kBinEdges;
  for (const LidarPoint& p : scan) {
    const Eigen::Vector3d r = T * Eigen::Vector3d(p.x, p.y, p.z);
    if (!(r.z() >= edges[0] && r.z() < edges[DisparityResidual::kBins])) continue;
    double d = 0;
    if (!cloud.disparityAt(cloud.fx * r.x() / r.z() + cloud.cx, cloud.fy * r.y() / r.z() + cloud.cy,
                           &d))
      continue;
    const double diff = d - cloud.fx * cloud.baseline / r.z();
    if (std::fabs(diff) > 3.0) continue;
    all.push_back(diff);
    int b = 0;
    while (r.z() >= edges[b + 1]) ++b;
    bins[b].push_back(diff);
  }
  out.points = static_cast<int>(all.size());
  out.median_px = medianOf(all);
  for (int b = 0; b < DisparityResidual::kBins; ++b) {
    out.bin_points[b] = static_cast<int>(bins[b].size());
    out.bin_median_px[b] = medianOf(bins[b]);
  }
  return out;
}

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
    J.emplace_back(1.0, (from[i].x - rig.left.cx) / rig.left.fx,
                   (from[i].y - rig.left.cy) / rig.left.fy);
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

ImageQuality imageQuality(const cv::Mat& image) {
  ImageQuality q;
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4))
    throw DataError("image quality: the image must be 8-bit grey, BGR or BGRA (got depth " +
                    std::to_string(image.depth()) + ", " + std::to_string(image.channels()) +
                    " channels)");
  if (image.empty()) return q;
  const cv::Mat g = grey(image);  // COLOR_BGR2GRAY takes BGRA too
  cv::Scalar mean, sd;
  cv::meanStdDev(g, mean, sd);
  q.contrast = sd[0];
  q.clipped_fraction =
      static_cast<double>(cv::countNonZero(g <= 2) + cv::countNonZero(g >= 253)) / g.total();
  const auto gradient = [](const cv::Mat& m) {
    cv::Mat gx, gy;
    cv::Sobel(m, gx, CV_16S, 1, 0);
    cv::Sobel(m, gy, CV_16S, 0, 1);
    return cv::mean(cv::abs(gx))[0] + cv::mean(cv::abs(gy))[0];
  };
  cv::Mat smooth;
  cv::GaussianBlur(g, smooth, cv::Size(0, 0), 2.0);
  const double coarse = gradient(smooth);
  q.sharpness = coarse > 0 ? gradient(g) / coarse : 0;
  return q;
}

std::string pairQualityProblem(const cv::Mat& left, const cv::Mat& right,
                               const ImageQualitySettings& s, ImageQuality* left_quality,
                               ImageQuality* right_quality) {
  const ImageQuality l = imageQuality(left), r = imageQuality(right);
  if (left_quality) *left_quality = l;
  if (right_quality) *right_quality = r;
  char buf[400];
  for (const auto& [name, q] : {std::pair<const char*, const ImageQuality&>{"left", l},
                                std::pair<const char*, const ImageQuality&>{"right", r}}) {
    if (q.contrast < s.min_contrast) {
      std::snprintf(buf, sizeof buf,
                    "the %s image has almost no contrast (grey values' standard deviation %.2f, "
                    "images/min_contrast %.2f): a dark, covered or blinded camera?",
                    name, q.contrast, s.min_contrast);
      return buf;
    }
  }
  const double clipped = r.clipped_fraction - l.clipped_fraction;
  if (std::fabs(clipped) > s.max_clipped_difference) {
    const char* worse = clipped > 0 ? "right" : "left";
    const char* better = clipped > 0 ? "left" : "right";
    std::snprintf(buf, sizeof buf,
                  "%.1f %% of the %s image's pixels are black or saturated against %.1f %% of the "
                  "%s one's (images/max_clipped_difference %.3f, a share): a blinded or partly "
                  "covered %s camera, or its exposure?",
                  100 * std::max(l.clipped_fraction, r.clipped_fraction), worse,
                  100 * std::min(l.clipped_fraction, r.clipped_fraction), better,
                  s.max_clipped_difference, worse);
    return buf;
  }
  if (s.min_sharpness_ratio > 0 && l.sharpness > 0 && r.sharpness > 0) {
    const double ratio = r.sharpness / l.sharpness;
    if (ratio < s.min_sharpness_ratio || ratio > 1.0 / s.min_sharpness_ratio) {
      const char* softer = ratio < 1 ? "right" : "left";
      const char* sharper = ratio < 1 ? "left" : "right";
      std::snprintf(buf, sizeof buf,
                    "the %s image has much less fine detail than the %s one (sharpness ratio "
                    "right / left %.3f, images/min_sharpness_ratio %.3f allows %.3f-%.3f): a "
                    "defocused %s camera, a wet or dirty window in front of it, or a noisy %s "
                    "one?",
                    softer, sharper, ratio, s.min_sharpness_ratio, s.min_sharpness_ratio,
                    1.0 / s.min_sharpness_ratio, softer, sharper);
      return buf;
    }
  }
  return {};
}

}  // namespace tescalib
