#include "tescalib/ros/overlay_nodelet.h"

#include <pluginlib/class_list_macros.hpp>

#include "tescalib/core/overlay.h"
#include "tescalib/ros/conversions.h"

namespace tescalib {

void OverlayNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  pnh.param("max_depth", max_depth_, max_depth_);
  left_pub_ = pnh.advertise<Image>("left/overlay", 1);
  right_pub_ = pnh.advertise<Image>("right/overlay", 1);
  lidar_est_sub_ = nh.subscribe<ExtrinsicEstimate>("lidar_to_left", 1,
                                                   [this](const ExtrinsicEstimate::ConstPtr& m) {
                                                     std::lock_guard<std::mutex> lock(mutex_);
                                                     lidar_est_ = *m;
                                                   });
  stereo_est_sub_ = nh.subscribe<ExtrinsicEstimate>("left_to_right", 1,
                                                    [this](const ExtrinsicEstimate::ConstPtr& m) {
                                                      std::lock_guard<std::mutex> lock(mutex_);
                                                      stereo_est_ = *m;
                                                    });
  cloud_sub_.subscribe(nh, "points", 2);
  left_sub_.subscribe(nh, "left/image_raw", 2);
  left_info_sub_.subscribe(nh, "left/camera_info", 2);
  right_sub_.subscribe(nh, "right/image_raw", 2);
  right_info_sub_.subscribe(nh, "right/camera_info", 2);
  sync_ = std::make_unique<message_filters::Synchronizer<Policy>>(
      Policy(5), cloud_sub_, left_sub_, left_info_sub_, right_sub_, right_info_sub_);
  sync_->registerCallback(&OverlayNodelet::onSet, this);
}

void OverlayNodelet::onSet(const Cloud::ConstPtr& cloud, const Image::ConstPtr& left,
                           const Info::ConstPtr& li, const Image::ConstPtr& right,
                           const Info::ConstPtr& ri) {
  if (left_pub_.getNumSubscribers() == 0 && right_pub_.getNumSubscribers() == 0) return;
  std::optional<ExtrinsicEstimate> le, se;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    le = lidar_est_, se = stereo_est_;
  }
  if (!le) {
    NODELET_INFO_THROTTLE(10.0, "tescalib overlay: waiting for the first lidar_to_left estimate");
    return;
  }
  LidarScan scan;
  cv::Mat l, r;
  CameraIntrinsics lc, rc;
  std::string error;
  if (!ros_conv::fromPointCloud2(*cloud, &scan, &error) || !ros_conv::toBgr8(*left, &l, &error) ||
      !ros_conv::fromCameraInfo(*li, &lc, &error)) {
    NODELET_WARN_THROTTLE(10.0, "tescalib overlay: %s", error.c_str());
    return;
  }
  const Eigen::Isometry3d T_cl = ros_conv::fromTransformMsg(le->transform);
  drawLidarOverlay(scan, T_cl, lc, &l, max_depth_);
  left_pub_.publish(ros_conv::toImageMsg(l, left->header, "bgr8"));
  if (se && ros_conv::toBgr8(*right, &r, &error) && ros_conv::fromCameraInfo(*ri, &rc, &error)) {
    drawLidarOverlay(scan, ros_conv::fromTransformMsg(se->transform) * T_cl, rc, &r, max_depth_);
    right_pub_.publish(ros_conv::toImageMsg(r, right->header, "bgr8"));
  }
}

}  // namespace tescalib

PLUGINLIB_EXPORT_CLASS(tescalib::OverlayNodelet, nodelet::Nodelet)
