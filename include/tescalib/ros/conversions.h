// Every ROS <-> core conversion lives here (unit-tested without a master in test_ros).
#pragma once

#include <string>
#include <vector>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <tescalib/ExtrinsicEstimate.h>
#include <visualization_msgs/Marker.h>
#include <opencv2/core.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/types.h"
#include "tescalib/core/lidar/lidar_mesh.h"
#include "tescalib/core/stereo/stereo_cloud.h"
#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/core/validation/window_quality.h"

namespace tescalib {
namespace ros_conv {

/// LidarScan -> PointCloud2 with fields x y z intensity (float32) and ring (uint16), as the
/// velodyne driver publishes them.
sensor_msgs::PointCloud2 toPointCloud2(const LidarScan& scan, const std_msgs::Header& header);
/// The scan as kitti2bag writes it: float32 x y z i, no ring field.
sensor_msgs::PointCloud2 toPointCloud2Xyzi(const LidarScan& scan, const std_msgs::Header& header);

/// PointCloud2 -> LidarScan. Needs float32 x y z; intensity (float32 or uint8/uint16) is
/// optional; a missing ring field is recovered from scan order (recoverRings). Non-finite points
/// are dropped. Returns false and fills `error` on a cloud that cannot be used.
bool fromPointCloud2(const sensor_msgs::PointCloud2& msg, LidarScan* scan, std::string* error,
                     bool* ring_recovered = nullptr);

/// The name of a per-point time field ("time": velodyne_pointcloud, "t": Ouster, "timestamp":
/// Hesai, "time_stamp"), or "" when there is none. Such a field marks a raw sweep, whose points
/// the vehicle's motion skews (deskew/enabled).
std::string perPointTimeField(const sensor_msgs::PointCloud2& msg);

/// Rectified camera intrinsics -> CameraInfo (K = P's left 3x3, R = I, D = 0). `p3` is P's fourth
/// column, K times the camera's position in the pair's reference frame: (0, 0, 0) for the left
/// camera and (-fx * baseline, 0, 0) for the right one in ROS's convention; KITTI's calibration
/// (P2, P3) and kitti2bag's bags measure both from the grey camera cam0 instead.
sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& c, const Eigen::Vector3d& p3,
                                     const std_msgs::Header& header);
/// The same with P = [K | (Tx, 0, 0)].
sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& c, double Tx,
                                     const std_msgs::Header& header);

/// CameraInfo -> intrinsics of the delivered image, taken from P (the rectified projection) with
/// the region of interest and binning applied as image_geometry does. Returns false with a
/// message when P is zero, the size is missing or the ROI lies outside the image.
bool fromCameraInfo(const sensor_msgs::CameraInfo& info, CameraIntrinsics* c, std::string* error);

/// Both cameras' intrinsics from their camera_info and, with `baseline_from_p`, the rectified
/// pair's T_right_left = [I | K_r^-1 P_r[:,3] - K_l^-1 P_l[:,3]]: the difference of the two
/// cameras' positions that the fourth columns of their P give. In ROS's convention (left
/// P[3] = 0, right P[3] = -fx * baseline) that is (-baseline, 0, 0); in kitti2bag's bags, whose P
/// are KITTI's P_rect_02 / P_rect_03 (both measured from cam0, left P[3] = +44.9 px on
/// 2011_09_26), it is KITTI's own left-right translation, vertical part included, where the right
/// P[3] alone would make the baseline 12 % short. False with a message when either camera_info is
/// unusable or the right camera does not sit to the right of the left one.
bool stereoFromCameraInfo(const sensor_msgs::CameraInfo& left, const sensor_msgs::CameraInfo& right,
                          bool baseline_from_p, StereoRig* rig, std::string* error);

/// Image message (bgr8, rgb8, mono8, bgra8, rgba8, mono16) -> CV_8UC3 BGR. False with a message
/// on an encoding that cannot be used (Bayer: a raw image, not rectified). mono16 is scaled by
/// the bits its values use (12 for a 12-bit camera's 0-4095, at least 8); with `mono16_scale`,
/// a positive value is used as the scale and 0 is replaced by the one found, so that both images
/// of a stereo pair are scaled alike.
bool toBgr8(const sensor_msgs::Image& msg, cv::Mat* bgr, std::string* error,
            double* mono16_scale = nullptr);

/// The mono16 -> 8-bit scale for `images` together (255 / (2^bits - 1), bits those of the
/// brightest value among the mono16 ones, at least 8), so that a stereo pair is scaled alike and
/// the brighter image does not clip; 0 when none is mono16.
double mono16Scale(const std::vector<const sensor_msgs::Image*>& images);

/// A stereo pair's images -> CV_8UC3 BGR (toBgr8), mono16 ones with one scale (mono16Scale);
/// the error names the camera.
bool toBgr8Pair(const sensor_msgs::Image& left, const sensor_msgs::Image& right, cv::Mat* left_bgr,
                cv::Mat* right_bgr, std::string* error);

/// CV_8UC3 BGR image -> Image message with the given encoding ("bgr8" or "rgb8").
sensor_msgs::Image toImageMsg(const cv::Mat& bgr, const std_msgs::Header& header,
                              const std::string& encoding = "rgb8");

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& T);
Eigen::Isometry3d fromTransformMsg(const geometry_msgs::Transform& msg);

}  // namespace ros_conv
}  // namespace tescalib

namespace tescalib {
namespace ros_conv {

/// Fills an ExtrinsicEstimate: `T` maps child-frame points into the parent frame, `cov` is over
/// [phi; tau] in the parent frame (our convention), copied as is. `status`: empty for a
/// published estimate, why it was not published for a candidate. `estimated` false: `T` is the
/// given extrinsic (left_to_right without co-calibration), not an estimate, and no axis is
/// `observable`. `weakest`: the window's weakest direction (ratio 0: none). `covariance_known`
/// false (a solve that ended before its covariance): covariance unknown as sensor_msgs/Imu marks
/// it (-1 in the first element, 0 else), sigma_* -1.
ExtrinsicEstimate toEstimateMsg(const std_msgs::Header& header, const std::string& parent,
                                const std::string& child, const Eigen::Isometry3d& T,
                                const Matrix6d& cov, const bool observable[6], bool converged,
                                int keyframes, double cost, int iterations,
                                const std::string& status = "", bool estimated = true,
                                const WeakDirection& weakest = WeakDirection(),
                                bool covariance_known = true);

/// The quality_* fields of an estimate message from the window's scores.
void setQuality(const WindowQualityScores& q, ExtrinsicEstimate* m);

/// The same as a PoseWithCovarianceStamped (header.frame_id = parent). ROS orders the pose
/// covariance [x y z rx ry rz]; ours is [phi; tau]: the blocks are swapped. `estimated` false:
/// the covariance is unknown, marked as sensor_msgs/Imu does: -1 in its first element, 0 else.
geometry_msgs::PoseWithCovarianceStamped toPoseMsg(const std_msgs::Header& header,
                                                   const Eigen::Isometry3d& T, const Matrix6d& cov,
                                                   bool estimated = true);

/// A keyframe's stereo cloud (left camera frame) as PointCloud2 with fields x y z and disparity
/// (float32), for rviz.
sensor_msgs::PointCloud2 toPointCloud2(const StereoCloud& cloud, const std_msgs::Header& header);

/// A LiDAR mesh (LiDAR frame) as a TRIANGLE_LIST marker coloured by range (near red, far blue up
/// to `max_range`); at most `max_faces` faces (evenly decimated) keep the message small.
visualization_msgs::Marker toMeshMarker(const LidarMesh& mesh, const std_msgs::Header& header,
                                        size_t max_faces = 20000, double max_range = 40.0);

}  // namespace ros_conv
}  // namespace tescalib
