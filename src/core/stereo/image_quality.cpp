#include "tescalib/core/stereo/image_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/image_sampling.h"

namespace tescalib {

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
