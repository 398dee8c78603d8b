// LiDAR-on-image overlay: the scan projected into an image with an extrinsic, coloured by depth.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"

namespace tescalib {

/// Draws the points of `scan` (LiDAR frame) that project into `image` (BGR) with `T_cam_lidar`
/// and intrinsics `cam`, coloured by depth (near red, far blue, up to `max_depth` m). Returns the
/// number of points drawn.
int drawLidarOverlay(const LidarScan& scan, const Eigen::Isometry3d& T_cam_lidar,
                     const CameraIntrinsics& cam, cv::Mat* image, double max_depth = 40.0);

/// Writes `lines` (e.g. the estimate's status) in the top-left corner of `image` (BGR) on a dark
/// band so they stay readable over any scene.
void drawStatusText(const std::vector<std::string>& lines, cv::Mat* image);

}  // namespace tescalib
