// Image access shared by the solvers and the checks: grey conversion and sub-pixel sampling.
#pragma once

#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace tescalib {

/// The image itself when it has one channel, else its grey conversion (BGR or BGRA).
inline cv::Mat grey(const cv::Mat& img) {
  if (img.channels() == 1) return img;
  cv::Mat g;
  cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  return g;
}

/// Bilinear value of a CV_64F image at (u, v) (pixel centres at integers); NaN outside.
inline double bilinear(const cv::Mat& img, double u, double v) {
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= img.cols || v0 + 1 >= img.rows) return std::nan("");
  const double fu = u - u0, fv = v - v0;
  return (1 - fv) * ((1 - fu) * img.at<double>(v0, u0) + fu * img.at<double>(v0, u0 + 1)) +
         fv * ((1 - fu) * img.at<double>(v0 + 1, u0) + fu * img.at<double>(v0 + 1, u0 + 1));
}

}  // namespace tescalib
