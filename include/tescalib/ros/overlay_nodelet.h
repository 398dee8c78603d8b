// tescalib/OverlayNodelet: the LiDAR scan drawn into the left image with the current LiDAR -> left
// estimate (and into the right image with the stereo estimate), for rviz; before the first
// estimate, with the last untrusted solve, labelled so.
#pragma once

#include <memory>
#include <mutex>
#include <optional>

#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include <tescalib/CalibrationStatus.h>
#include <tescalib/ExtrinsicEstimate.h>

namespace tescalib {

class OverlayNodelet : public nodelet::Nodelet {
 private:
  using Cloud = sensor_msgs::PointCloud2;
  using Image = sensor_msgs::Image;
  using Info = sensor_msgs::CameraInfo;
  using Policy = message_filters::sync_policies::ApproximateTime<Cloud, Image, Info, Image, Info>;

  void onInit() override;
  void onSet(const Cloud::ConstPtr& cloud, const Image::ConstPtr& left, const Info::ConstPtr& li,
             const Image::ConstPtr& right, const Info::ConstPtr& ri);

  std::unique_ptr<image_transport::ImageTransport> image_transport_;
  message_filters::Subscriber<Cloud> cloud_sub_;
  image_transport::SubscriberFilter left_sub_, right_sub_;  ///< through ~image_transport
  message_filters::Subscriber<Info> left_info_sub_, right_info_sub_;
  std::unique_ptr<message_filters::Synchronizer<Policy>> sync_;
  ros::Subscriber lidar_est_sub_, stereo_est_sub_, lidar_candidate_sub_, status_sub_;
  image_transport::Publisher left_pub_, right_pub_;
  std::mutex mutex_;
  std::optional<ExtrinsicEstimate> lidar_est_, stereo_est_;  ///< GUARDED_BY(mutex_)
  /// The calibration's last solve (candidate/lidar_to_left), drawn only while no estimate has
  /// been published, labelled as not trusted: on data where nothing converges (real KITTI) the
  /// overlay still shows where the window puts the LiDAR.
  std::optional<ExtrinsicEstimate> lidar_candidate_;  ///< GUARDED_BY(mutex_)
  /// The calibration monitor's states (~status): drawn while an extrinsic is not `calibrated`.
  std::optional<CalibrationStatus> status_;  ///< GUARDED_BY(mutex_)
  double max_depth_ = 40.0;
};

}  // namespace tescalib
