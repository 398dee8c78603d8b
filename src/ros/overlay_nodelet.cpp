#include "tescalib/ros/overlay_nodelet.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <ros/names.h>
#include <pluginlib/class_list_macros.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/overlay.h"
#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/ros/conversions.h"

namespace tescalib {
namespace {

/// The monitor's line for the overlay while an extrinsic is suspect, changed or recalibrating,
/// e.g. "monitor: LiDAR->left suspect (the drawn extrinsic is the last published one)"; empty
/// otherwise.
std::string monitorLine(const CalibrationStatus& s) {
  std::string line;
  for (const auto& [name, state] :
       {std::pair<const char*, const std::string&>{"LiDAR->left", s.lidar_to_left},
        {"left->right", s.left_to_right}}) {
    if (state != "suspect" && state != "changed" && state != "recalibrating") continue;
    line += (line.empty() ? "monitor: " : "; ") + std::string(name) + " " + state;
  }
  return line.empty() ? line : line + " (the drawn extrinsic is the last published one)";
}

/// One status line of an estimate for the overlay image, e.g.
/// "LiDAR->left: converged, 10 kf, sigma <= 0.019 deg / 0.69 cm, weak: none".
std::string statusLine(const char* name, const ExtrinsicEstimate& e) {
  const double rot = *std::max_element(e.sigma_rot_deg.begin(), e.sigma_rot_deg.end());
  const double trans = *std::max_element(e.sigma_trans_m.begin(), e.sigma_trans_m.end());
  if (rot == 0 && trans == 0)   // T_right_left is the initial one: LiDAR-stereo only, or
    return std::string(name) +  // co-calibration has not run yet (co_calibration/lidar_first)
           ": fixed at its initial value (not estimated)";
  bool observable[6];
  std::copy(e.observable.begin(), e.observable.end(), observable);
  const std::string weak = untrustedAxes(observable);
  char sigma[64] = "no covariance";  // the solve ended before it (sigma -1: unknown)
  if (rot >= 0 && trans >= 0)
    std::snprintf(sigma, sizeof(sigma), "sigma <= %.3f deg / %.2f cm", rot, 100 * trans);
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s: %s, %u kf, %s, weak: %s", name,
                e.converged ? "converged" : "not converged", e.keyframes_used, sigma,
                weak.empty() ? "none" : weak.c_str());
  return buf;
}

}  // namespace

void OverlayNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  // Checked: a string would keep the default silently, 0 or less would draw nothing.
  double max_depth = max_depth_;
  if (pnh.hasParam("max_depth") &&
      !(pnh.getParam("max_depth", max_depth) && max_depth > 0 && std::isfinite(max_depth)))
    NODELET_ERROR(
        "~max_depth must be a number > 0 m (points are coloured by depth up to it); "
        "keeping %.0f m",
        max_depth_);
  else
    max_depth_ = max_depth;
  // Images in and out through image_transport: ~image_transport names the input's transport
  // (raw by default); the overlays are offered on every transport installed.
  image_transport_ = std::make_unique<image_transport::ImageTransport>(nh);
  image_transport::ImageTransport private_it(pnh);
  left_pub_ = private_it.advertise("left/overlay", 1);
  right_pub_ = private_it.advertise("right/overlay", 1);
  lidar_est_sub_ = nh.subscribe<ExtrinsicEstimate>("lidar_to_left", 1,
                                                   [this](const ExtrinsicEstimate::ConstPtr& m) {
                                                     std::lock_guard<std::mutex> lock(mutex_);
                                                     lidar_est_ = *m;
                                                   });
  lidar_candidate_sub_ = nh.subscribe<ExtrinsicEstimate>(
      "candidate/lidar_to_left", 1, [this](const ExtrinsicEstimate::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        lidar_candidate_ = *m;
      });
  stereo_est_sub_ = nh.subscribe<ExtrinsicEstimate>("left_to_right", 1,
                                                    [this](const ExtrinsicEstimate::ConstPtr& m) {
                                                      std::lock_guard<std::mutex> lock(mutex_);
                                                      stereo_est_ = *m;
                                                    });
  status_sub_ =
      nh.subscribe<CalibrationStatus>("status", 1, [this](const CalibrationStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        status_ = *m;
      });
  // ~image_transport, or else the calibration nodelet's (whose estimates it draws: the
  // namespace lidar_to_left resolves into), so that a config's transport reaches both.
  std::string transport;
  if (!pnh.getParam("image_transport", transport))
    nh.param(ros::names::parentNamespace(nh.resolveName("lidar_to_left")) + "/image_transport",
             transport, std::string("raw"));
  const image_transport::TransportHints hints(transport, ros::TransportHints(), pnh);
  try {  // resolved here: image_transport's Subscriber does not resolve remapped base topics
    left_sub_.subscribe(*image_transport_, nh.resolveName("left/image_raw"), 2, hints);
    right_sub_.subscribe(*image_transport_, nh.resolveName("right/image_raw"), 2, hints);
  } catch (const std::exception& ex) {
    NODELET_FATAL("tescalib overlay: image_transport \"%s\" cannot be used: %s", transport.c_str(),
                  ex.what());
    return;
  }
  cloud_sub_.subscribe(nh, "points", 2);
  left_info_sub_.subscribe(nh, "left/camera_info", 2);
  right_info_sub_.subscribe(nh, "right/camera_info", 2);
  sync_ = std::make_unique<message_filters::Synchronizer<Policy>>(
      Policy(5), cloud_sub_, left_sub_, left_info_sub_, right_sub_, right_info_sub_);
  sync_->registerCallback(&OverlayNodelet::onSet, this);
}

void OverlayNodelet::onSet(const Cloud::ConstPtr& cloud, const Image::ConstPtr& left,
                           const Info::ConstPtr& li, const Image::ConstPtr& right,
                           const Info::ConstPtr& ri) {
  if (left_pub_.getNumSubscribers() == 0 && right_pub_.getNumSubscribers() == 0) return;
  std::optional<ExtrinsicEstimate> le, se, candidate;
  std::optional<CalibrationStatus> monitor;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    le = lidar_est_, se = stereo_est_, candidate = lidar_candidate_, monitor = status_;
  }
  LidarScan scan;
  cv::Mat l, r;
  CameraIntrinsics lc, rc;
  std::string error;
  if (!ros_conv::toBgr8(*left, &l, &error)) {
    NODELET_WARN_THROTTLE(10.0, "tescalib overlay: %s", error.c_str());
    return;
  }
  const bool have_scan = ros_conv::fromPointCloud2(*cloud, &scan, &error) &&
                         ros_conv::fromCameraInfo(*li, &lc, &error);
  if (!have_scan) NODELET_WARN_THROTTLE(10.0, "tescalib overlay: %s", error.c_str());
  if (!le) {  // what the node waits for, and the last untrusted solve when there is one
    std::vector<std::string> status{
        "tescalib: waiting for the first converged LiDAR->left estimate"};
    if (candidate && have_scan) {
      drawLidarOverlay(scan, ros_conv::fromTransformMsg(candidate->transform), lc, &l, max_depth_);
      status.push_back("drawn: the last solve, NOT TRUSTED - " +
                       statusLine("LiDAR->left", *candidate));
      for (size_t i = 0; i < candidate->status.size() && i < 360; i += 120)
        status.push_back((i ? "  " : "  why: ") + candidate->status.substr(i, 120));
    }
    drawStatusText(status, &l);
    left_pub_.publish(ros_conv::toImageMsg(l, left->header, "bgr8"));
    // The right pane says the same instead of staying empty (the whole run on data the node
    // never trusts, real KITTI).
    if (ros_conv::toBgr8(*right, &r, &error)) {
      drawStatusText({status.front(), "the right image's overlay needs it (and left->right)"}, &r);
      right_pub_.publish(ros_conv::toImageMsg(r, right->header, "bgr8"));
    }
    return;
  }
  if (!have_scan) return;
  const Eigen::Isometry3d T_cl = ros_conv::fromTransformMsg(le->transform);
  drawLidarOverlay(scan, T_cl, lc, &l, max_depth_);
  std::vector<std::string> status{statusLine("LiDAR->left", *le)};
  if (se) status.push_back(statusLine("left->right", *se));
  if (monitor) {
    const std::string line = monitorLine(*monitor);
    if (!line.empty()) status.push_back(line);
  }
  drawStatusText(status, &l);
  left_pub_.publish(ros_conv::toImageMsg(l, left->header, "bgr8"));
  if (se && ros_conv::toBgr8(*right, &r, &error) && ros_conv::fromCameraInfo(*ri, &rc, &error)) {
    drawLidarOverlay(scan, ros_conv::fromTransformMsg(se->transform) * T_cl, rc, &r, max_depth_);
    right_pub_.publish(ros_conv::toImageMsg(r, right->header, "bgr8"));
  }
}

}  // namespace tescalib

PLUGINLIB_EXPORT_CLASS(tescalib::OverlayNodelet, nodelet::Nodelet)
