// OpenCV's semi-global block matching of a rectified grey pair, as the stereo clouds use it
// (StereoSettings: aggregation paths, upright and upside down), with its disparities in px
// without OpenCV's rounding bias.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

/// SGBM's disparity `v` (16 x px, > 0) in px, without OpenCV's rounding bias. OpenCV adds the cost
/// parabola's sub-pixel offset x (in 1/16 px, |x| <= 8) to 16 d as the integer quotient
/// (16 (S[d-1] - S[d+1]) + D) / (2 D), D the parabola's curvature: trunc(x + 1/2), the nearest
/// 1/16 for x >= -1/2, but C++ division truncates towards zero, so every x in (-3/2, 1/2) gives 0
/// and every lower x one 1/16 too much. A value therefore stands for the middle of the offsets
/// that give it: v - 1 for a residue (v mod 16) of 9 to 15 (a negative offset), v - 1/2 for a
/// residue of 0, v for 1 to 8. Taken as they are, the disparities are about 0.03 px too large at
/// every depth (sub-pixel offsets spread evenly: 7.5 / 16 of 1/16 px).
float sgbmDisparityPx(int16_t v);

/// The disparity of the rectified grey pair (8-bit, one size) in px: SGBM with `s`'s block size,
/// range, checks and paths, matched upright and, with `s.sgbm_both_ways`, upside down as well
/// (the mean of the two where they lie within `s.both_ways_max_diff_px`); NaN where invalid,
/// below `min_disparity_px` or in the first `s.num_disparities` columns (which SGBM leaves
/// unmatched).
cv::Mat sgbmDisparity(const cv::Mat& left, const cv::Mat& right, const StereoSettings& s,
                      double min_disparity_px);

}  // namespace tescalib
