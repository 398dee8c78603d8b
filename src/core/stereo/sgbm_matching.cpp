#include "tescalib/core/stereo/sgbm_matching.h"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>

namespace tescalib {
namespace {

/// OpenCV's SGBM mode with `paths` aggregation paths (3, 5 or 8; checked by the stereo cloud's
/// input checks).
int sgbmMode(int paths) {
  if (paths == 8) return cv::StereoSGBM::MODE_HH;
  return paths == 5 ? cv::StereoSGBM::MODE_SGBM : cv::StereoSGBM::MODE_SGBM_3WAY;
}

/// One SGBM pass's disparities in px (sgbmDisparityPx), NaN where invalid, below `min_d` or in
/// the first `first_col` columns; `flip_rows` turns an upside-down pass's rows back.
cv::Mat disparityPx(const cv::Mat& disp16, float min_d, int first_col, bool flip_rows) {
  cv::Mat disp(disp16.size(), CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < disp16.rows; ++v) {
    const int16_t* in = disp16.ptr<int16_t>(flip_rows ? disp16.rows - 1 - v : v);
    float* o = disp.ptr<float>(v);
    for (int u = 0; u < disp16.cols; ++u) {
      const float d = in[u] > 0 ? sgbmDisparityPx(in[u]) : nan;
      o[u] = (!(d >= min_d) || u < first_col) ? nan : d;
    }
  }
  return disp;
}

/// Where the upside-down pass (`flipped`, px, its rows turned back) lies within `max_diff_px` of
/// the upright one, `disp` takes their mean; elsewhere (a depth edge, a repeated texture: two
/// different matches) NaN.
void keepMeanOfBothWays(const cv::Mat& flipped, double max_diff_px, cv::Mat* disp) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < disp->rows; ++v) {
    float* a = disp->ptr<float>(v);
    const float* b = flipped.ptr<float>(v);
    for (int u = 0; u < disp->cols; ++u)
      a[u] = std::fabs(a[u] - b[u]) <= max_diff_px ? 0.5f * (a[u] + b[u]) : nan;
  }
}

}  // namespace

float sgbmDisparityPx(int16_t v) {
  const int residue = v & 15;
  const float unbias = residue == 0 ? 0.5f : residue >= 9 ? 1.f : 0.f;
  return (static_cast<float>(v) - unbias) / 16.f;
}

cv::Mat sgbmDisparity(const cv::Mat& left, const cv::Mat& right, const StereoSettings& s,
                      double min_disparity_px) {
  const int bs = s.block_size;
  auto sgbm = cv::StereoSGBM::create(0, s.num_disparities, bs, 8 * bs * bs, 32 * bs * bs,
                                     s.disp12_max_diff, 0, s.uniqueness_ratio, s.speckle_window,
                                     s.speckle_range, sgbmMode(s.sgbm_paths));
  const float min_d = static_cast<float>(min_disparity_px);
  cv::Mat disp16;
  sgbm->compute(left, right, disp16);
  cv::Mat disp = disparityPx(disp16, min_d, s.num_disparities, false);
  if (!s.sgbm_both_ways) return disp;
  cv::Mat left_flipped, right_flipped, flipped_disp16;
  cv::flip(left, left_flipped, 0);
  cv::flip(right, right_flipped, 0);
  sgbm->compute(left_flipped, right_flipped, flipped_disp16);
  keepMeanOfBothWays(disparityPx(flipped_disp16, min_d, s.num_disparities, true),
                     s.both_ways_max_diff_px, &disp);
  return disp;
}

}  // namespace tescalib
