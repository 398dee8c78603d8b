// Edge alignment (Levinson and Thrun, "Automatic online calibration of cameras and lasers",
// RSS 2013): LiDAR points at depth discontinuities, on their foreground side, fall on image edges
// when the calibration is right. The image side is an edge-strength map that is spread out with a
// decaying maximum, so that a point a few pixels beside an edge still scores, and less than on it.
#pragma once

#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"

namespace tescalib {

struct EdgeAlignmentSettings {
  double blur_sigma_px = 1.0;      ///< Gaussian blur of the grey image before its gradient
  double spread_decay = 0.8;       ///< the spread map loses this factor per pixel from an edge
  int spread_px = 8;               ///< how far an edge spreads (px)
  double edge_weight = 1.0 / 3.0;  ///< share of the sharp edge map in the score map (alpha)
  double min_jump_m = 0.5;         ///< a discontinuity: the ring neighbour this much farther ...
  double min_jump_fraction = 0.1;  ///< ... and this fraction of the point's range farther
  double max_jump_m = 4.0;         ///< jumps count up to this size (weight sqrt(jump))
  double min_range_m = 2.0, max_range_m = 50.0;
};

/// A LiDAR point on the foreground side of a depth discontinuity, with its weight.
struct EdgePoint {
  Eigen::Vector3d p;  ///< LiDAR frame
  double weight = 0;
};

/// The image's edge-strength map (CV_64F, 0..1): the blurred grey gradient magnitude divided by
/// its 98th percentile and clipped at 1 (e), spread as D = max(e, decay * dilate(D)) over
/// `spread_px` pixels, and mixed as edge_weight * e + (1 - edge_weight) * D.
cv::Mat edgeStrengthMap(const cv::Mat& bgr, const EdgeAlignmentSettings& s = {});

/// The scan's points whose neighbour along the ring (range image, azimuth neighbours) is farther
/// by more than both jump thresholds: the near side of an object's silhouette.
std::vector<EdgePoint> depthDiscontinuities(const LidarScan& scan,
                                            const EdgeAlignmentSettings& s = {});

/// The weighted mean edge strength at the points' projections into one camera (T_cam_lidar maps
/// LiDAR points into that camera); points behind it or outside the image are left out. `points`
/// receives how many were inside. 0 when none was.
double edgeAlignment(const std::vector<EdgePoint>& points, const cv::Mat& edge_map,
                     const CameraIntrinsics& cam, const Eigen::Isometry3d& T_cam_lidar,
                     int* points_inside = nullptr);

}  // namespace tescalib
