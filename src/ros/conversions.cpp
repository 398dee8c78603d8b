#include "tescalib/ros/conversions.h"

#include <algorithm>
#include <cmath>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace ros_conv {

sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& c, const Eigen::Vector3d& p3,
                                     const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(c.width);
  info.height = static_cast<uint32_t>(c.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {c.fx, 0, c.cx, p3.x(), 0, c.fy, c.cy, p3.y(), 0, 0, 1, p3.z()};
  return info;
}

sensor_msgs::CameraInfo toCameraInfo(const CameraIntrinsics& c, double Tx,
                                     const std_msgs::Header& header) {
  return toCameraInfo(c, Eigen::Vector3d(Tx, 0, 0), header);
}

bool fromCameraInfo(const sensor_msgs::CameraInfo& info, CameraIntrinsics* c, std::string* error) {
  if (info.width == 0 || info.height == 0) {
    *error = "camera_info has no image size";
    return false;
  }
  if (info.P[0] <= 0 || info.P[5] <= 0) {
    *error = "camera_info has no rectified projection matrix P";
    return false;
  }
  // The delivered image is the region of interest (full-resolution pixels) binned, as
  // image_geometry::PinholeCameraModel reads camera_info: P describes the full image.
  const double bx = std::max(1u, info.binning_x), by = std::max(1u, info.binning_y);
  const bool roi = info.roi.width > 0 && info.roi.height > 0;
  if (roi &&
      (info.roi.x_offset > info.width || info.roi.width > info.width - info.roi.x_offset ||
       info.roi.y_offset > info.height || info.roi.height > info.height - info.roi.y_offset)) {
    *error = "camera_info's roi lies outside its " + std::to_string(info.width) + "x" +
             std::to_string(info.height) + " image";
    return false;
  }
  c->fx = info.P[0] / bx;
  c->fy = info.P[5] / by;
  c->cx = (info.P[2] - (roi ? info.roi.x_offset : 0)) / bx;
  c->cy = (info.P[6] - (roi ? info.roi.y_offset : 0)) / by;
  c->width = static_cast<int>((roi ? info.roi.width : info.width) / bx);
  c->height = static_cast<int>((roi ? info.roi.height : info.height) / by);
  return true;
}

bool stereoFromCameraInfo(const sensor_msgs::CameraInfo& left, const sensor_msgs::CameraInfo& right,
                          bool baseline_from_p, StereoRig* rig, std::string* error) {
  if (!fromCameraInfo(left, &rig->left, error) || !fromCameraInfo(right, &rig->right, error)) {
    *error = "unusable camera_info: " + *error;
    return false;
  }
  if (!baseline_from_p) return true;
  // P = K [I | t]: t = K^-1 P[:,3] is the camera's position (negated, in its own axes) in the
  // frame both P refer to; the rectified cameras share their orientation.
  // With P's own (full-resolution) K: binning and ROI do not move the cameras.
  const auto position = [](const sensor_msgs::CameraInfo& info) {
    Eigen::Matrix3d K;
    K << info.P[0], info.P[1], info.P[2], 0, info.P[5], info.P[6], 0, 0, 1;
    return Eigen::Vector3d(K.inverse() * Eigen::Vector3d(info.P[3], info.P[7], info.P[11]));
  };
  const Eigen::Vector3d t = position(right) - position(left);
  if (t.allFinite() && t.x() < 0 && std::hypot(t.y(), t.z()) > 0.2 * -t.x()) {
    *error = "the camera_infos put the right camera at (" + std::to_string(t.x()) + ", " +
             std::to_string(t.y()) + ", " + std::to_string(t.z()) +
             ") m from the left one: not side by side (vertical or diagonal stereo), which "
             "tescalib's row-wise stereo matching cannot use";
    return false;
  }
  if (!(t.x() < 0) || !t.allFinite()) {
    *error = "right camera_info P[3] = " + std::to_string(right.P[3]) + " with the left one's " +
             std::to_string(left.P[3]) +
             ": the right camera must sit to the right of the left one (its P[3] = -fx*baseline "
             "relative to the left camera's); set initial/T_right_left";
    return false;
  }
  // KITTI-style P measure both cameras from a reference one, so the left P[3] may be non-zero;
  // the right one's is never 0 in a calibrated pair. A right P without it put the "baseline" at
  // the left camera's offset from that reference (0.06 m on KITTI, 0.54 m true).
  if (right.P[3] == 0) {
    *error = "right camera_info P[3] = 0 (with the left one's " + std::to_string(left.P[3]) +
             "): the right camera_info holds no baseline (its P must be K [I | t], P[3] = "
             "-fx*baseline relative to the left camera's); set initial/T_right_left";
    return false;
  }
  rig->T_right_left = Eigen::Isometry3d::Identity();
  rig->T_right_left.translation() = t;
  return true;
}

double mono16Scale(const std::vector<const sensor_msgs::Image*>& images) {
  // The bits the images use (a 12-bit camera's values end at 4095): dividing by 256 would leave
  // such an image 16 grey levels. The brightest of the images sets it, so none of them clips.
  double max_value = -1;
  for (const sensor_msgs::Image* m : images) {
    if (!m || m->encoding != sensor_msgs::image_encodings::MONO16) continue;
    try {
      double v = 0;
      cv::minMaxLoc(cv_bridge::toCvCopy(*m, sensor_msgs::image_encodings::MONO16)->image, nullptr,
                    &v);
      max_value = std::max(max_value, v);
    } catch (const cv_bridge::Exception&) {
    }  // toBgr8 reports it
  }
  if (max_value < 0) return 0.0;
  const int bits = std::clamp(int(std::ceil(std::log2(max_value + 1.0))), 8, 16);
  return 255.0 / ((1 << bits) - 1);
}

bool toBgr8(const sensor_msgs::Image& msg, cv::Mat* bgr, std::string* error, double* mono16_scale) {
  namespace enc = sensor_msgs::image_encodings;
  const std::string& e = msg.encoding;
  if (enc::isBayer(e)) {
    *error = "image encoding '" + e +
             "' is a camera's raw (Bayer) output, which is not rectified: run stereo_image_proc "
             "and remap left/image_raw and right/image_raw to its image_rect_color topics";
    return false;
  }
  if (e != enc::BGR8 && e != enc::RGB8 && e != enc::MONO8 && e != enc::BGRA8 && e != enc::RGBA8 &&
      e != enc::MONO16) {
    *error = "unsupported image encoding '" + e + "' (use bgr8, rgb8, mono8, bgra8, rgba8, mono16)";
    return false;
  }
  if (msg.width == 0 || msg.height == 0 || msg.data.size() < size_t(msg.step) * msg.height) {
    *error = "image is empty or its data is shorter than step*height";
    return false;
  }
  try {
    if (e == enc::MONO16) {
      const auto cv = cv_bridge::toCvCopy(msg, enc::MONO16);
      double scale = mono16_scale ? *mono16_scale : 0.0;
      if (!(scale > 0)) {
        scale = mono16Scale({&msg});
        if (mono16_scale) *mono16_scale = scale;
      }
      cv::Mat m8;
      cv->image.convertTo(m8, CV_8U, scale);
      cv::cvtColor(m8, *bgr, cv::COLOR_GRAY2BGR);
    } else {
      *bgr = cv_bridge::toCvCopy(msg, enc::BGR8)->image;
    }
  } catch (const cv_bridge::Exception& ex) {
    *error = std::string("cv_bridge: ") + ex.what();
    return false;
  }
  return true;
}

bool toBgr8Pair(const sensor_msgs::Image& left, const sensor_msgs::Image& right, cv::Mat* left_bgr,
                cv::Mat* right_bgr, std::string* error) {
  double scale = mono16Scale({&left, &right});
  if (!toBgr8(left, left_bgr, error, &scale)) {
    *error = "left image: " + *error;
    return false;
  }
  if (!toBgr8(right, right_bgr, error, &scale)) {
    *error = "right image: " + *error;
    return false;
  }
  return true;
}

sensor_msgs::Image toImageMsg(const cv::Mat& bgr, const std_msgs::Header& header,
                              const std::string& encoding) {
  cv::Mat out = bgr;
  if (encoding == sensor_msgs::image_encodings::RGB8) cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
  sensor_msgs::Image msg;
  cv_bridge::CvImage(header, encoding, out).toImageMsg(msg);
  return msg;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& T) {
  return tf2::eigenToTransform(T).transform;
}

/// Not tf2::transformToEigen: that one takes the quaternion as it comes, where a hand-written
/// or rounded one (a bag's /tf_static, a parameter) is normalised first.
Eigen::Isometry3d fromTransformMsg(const geometry_msgs::Transform& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(m.rotation.w, m.rotation.x, m.rotation.y, m.rotation.z)
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(m.translation.x, m.translation.y, m.translation.z);
  return T;
}

}  // namespace ros_conv
}  // namespace tescalib

namespace tescalib {
namespace ros_conv {

ExtrinsicEstimate toEstimateMsg(const std_msgs::Header& header, const std::string& parent,
                                const std::string& child, const Eigen::Isometry3d& T,
                                const Matrix6d& cov, const bool observable[6], bool converged,
                                int keyframes, double cost, int iterations,
                                const std::string& status, bool estimated,
                                const WeakDirection& weakest, bool covariance_known) {
  ExtrinsicEstimate m;
  m.header = header;
  m.header.frame_id = parent;
  m.parent_frame_id = parent;
  m.child_frame_id = child;
  m.transform = toTransformMsg(T);
  for (int i = 0; i < 36; ++i) m.covariance[i] = cov(i / 6, i % 6);
  for (int i = 0; i < 3; ++i) {
    m.sigma_rot_deg[i] = std::sqrt(std::max(0.0, cov(i, i))) * kDegPerRad;
    m.sigma_trans_m[i] = std::sqrt(std::max(0.0, cov(3 + i, 3 + i)));
  }
  // A given extrinsic constrains nothing from the data: no axis is called observable.
  for (int i = 0; i < 6; ++i) m.observable[i] = estimated && observable[i];
  m.converged = converged;
  m.estimated = estimated;
  m.keyframes_used = static_cast<uint32_t>(keyframes);
  m.final_cost = cost;
  m.iterations = static_cast<uint32_t>(iterations);
  m.status = status;
  if (estimated && weakest.ratio > 0) {
    for (int i = 0; i < 6; ++i) m.weakest_direction[i] = weakest.direction[i];
    m.weakest_ratio = weakest.ratio;
  }
  if (estimated && !covariance_known) {  // a placeholder is no uncertainty: unknown, not exact
    m.covariance.fill(0.0);
    m.covariance[0] = -1.0;
    m.sigma_rot_deg.fill(-1.0);
    m.sigma_trans_m.fill(-1.0);
  }
  return m;
}

void setQuality(const WindowQualityScores& q, ExtrinsicEstimate* m) {
  m->quality_criteria.clear();
  m->quality_higher_is_better.clear();
  m->quality_estimate.clear();
  m->quality_initial.clear();
  m->quality_significant.clear();
  for (Criterion c : kAllCriteria) {
    m->quality_criteria.push_back(criterionName(c));
    m->quality_higher_is_better.push_back(higherIsBetter(c));
    m->quality_estimate.push_back(WindowQualityScores::mean(q.estimate, c));
    m->quality_initial.push_back(WindowQualityScores::mean(q.initial, c));
    m->quality_significant.push_back(significant(q.advantage(c)));
  }
  m->quality_keyframes = static_cast<uint32_t>(q.keyframes);
}

geometry_msgs::PoseWithCovarianceStamped toPoseMsg(const std_msgs::Header& header,
                                                   const Eigen::Isometry3d& T, const Matrix6d& cov,
                                                   bool estimated) {
  geometry_msgs::PoseWithCovarianceStamped m;
  m.header = header;
  const geometry_msgs::Transform t = toTransformMsg(T);
  m.pose.pose.position.x = t.translation.x;
  m.pose.pose.position.y = t.translation.y;
  m.pose.pose.position.z = t.translation.z;
  m.pose.pose.orientation = t.rotation;
  const int order[6] = {3, 4, 5, 0, 1, 2};  // ROS index -> our index
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) m.pose.covariance[6 * r + c] = cov(order[r], order[c]);
  if (!estimated) {  // unknown, as sensor_msgs/Imu marks it: not "exact" (zeros)
    m.pose.covariance.fill(0.0);
    m.pose.covariance[0] = -1.0;
  }
  return m;
}

}  // namespace ros_conv
}  // namespace tescalib
