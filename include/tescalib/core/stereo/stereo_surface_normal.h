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

/// The vector a fine LiDAR-stereo residual is measured along (LidarStereoSettings::
/// fine_stereo_normal_px), for a LiDAR face with normal `*face_normal` (left camera frame) whose
/// centroid projects to rectified pixel (u, v) along the camera ray `ray` (unit), where the
/// residual is the stereo point's distance to the face, f^T (c - p_s). As the estimate moves c,
/// p_s slides along the stereo surface (it stays on the ray through c), and the residual changes
/// by lambda n_s^T dc, n_s the stereo surface's normal (oriented like the face's) and
/// lambda = (f^T ray) / (n_s^T ray): the residual's derivative, which replaces `*face_normal`.
/// Its value at the association is the same (c - p_s lies along the ray). lambda is held within
/// 1/3 - 3 (beyond, a depth edge or a surface seen at a grazing angle: the stereo surface's
/// normal is not the surface's there). Returns whether it replaced the face's normal: not with
/// h = 0, on the ground's faces (normal within 37 deg of camera y), where the disparity shows no
/// surface (stereoSurfaceNormal) nor where the two surfaces face the camera from opposite sides.
bool fineResidualNormal(const StereoCloud& cloud, double u, double v, int h,
                        const Eigen::Vector3d& ray, Eigen::Vector3d* face_normal);

}  // namespace tescalib
