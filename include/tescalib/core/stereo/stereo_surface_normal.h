// The orientation of the surface a stereo cloud sees around a pixel, from its disparity alone.
#pragma once

#include <Eigen/Core>

#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

/// The unit normal (left camera frame, sign not fixed) of the plane that a weighted affine fit
/// d = d0 + a (u' - u) + b (v' - v) of the disparity around the rectified pixel (u, v)
/// describes: a plane in space has a disparity affine in the pixel, and fitting it in the
/// disparity, where SGBM's noise is about the same everywhere, averages that noise over the
/// patch. The weights fall linearly to 0 at h + 1 px from (u, v) in u and in v (a tent): the
/// normal changes continuously with (u, v). With h = 6 and independent pixel noise its slopes
/// are 4.5x less noisy than finite differences 6 px either side. False when less than 60 %
/// of the weight falls on pixels with a disparity (an edge, the image border) or `h` < 1.
bool stereoSurfaceNormal(const StereoCloud& cloud, double u, double v, int h,
                         Eigen::Vector3d* normal);

}  // namespace tescalib
