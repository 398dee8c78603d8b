#include "tescalib/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace ros_conv {

sensor_msgs::PointCloud2 toPointCloud2(const LidarScan& scan, const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 msg;
  msg.header = header;
  msg.height = 1;
  msg.width = static_cast<uint32_t>(scan.size());
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(
      5, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "intensity", 1, sensor_msgs::PointField::FLOAT32, "ring", 1,
      sensor_msgs::PointField::UINT16);
  mod.resize(scan.size());
  msg.is_dense = true;
  msg.is_bigendian = false;
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z"),
      i(msg, "intensity");
  sensor_msgs::PointCloud2Iterator<uint16_t> r(msg, "ring");
  for (const auto& p : scan) {
    *x = p.x;
    *y = p.y;
    *z = p.z;
    *i = p.intensity;
    *r = p.ring;
    ++x, ++y, ++z, ++i, ++r;
  }
  return msg;
}

namespace {
/// `n` points of float32 x y z and one more float32 field `fourth`, dense, little-endian: fill
/// them with xyzf().
sensor_msgs::PointCloud2 xyzfCloud(const std_msgs::Header& header, size_t n, const char* fourth) {
  sensor_msgs::PointCloud2 msg;
  msg.header = header;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, fourth, 1, sensor_msgs::PointField::FLOAT32);
  mod.resize(n);
  msg.is_dense = true;
  msg.is_bigendian = false;
  return msg;
}

template <typename Points, typename Xyzf>
void fillXyzf(const Points& points, const char* fourth, Xyzf xyzf, sensor_msgs::PointCloud2* msg) {
  sensor_msgs::PointCloud2Iterator<float> it(*msg, "x"), f(*msg, fourth);
  for (const auto& p : points) {
    xyzf(p, &it[0], &it[1], &it[2], &*f);
    ++it, ++f;
  }
}
}  // namespace

sensor_msgs::PointCloud2 toPointCloud2(const StereoCloud& cloud, const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 msg = xyzfCloud(header, cloud.points.size(), "disparity");
  fillXyzf(
      cloud.points, "disparity",
      [](const StereoPoint& p, float* x, float* y, float* z, float* d) {
        *x = p.p.x(), *y = p.p.y(), *z = p.p.z(), *d = p.disparity;
      },
      &msg);
  return msg;
}

sensor_msgs::PointCloud2 toPointCloud2Xyzi(const LidarScan& scan, const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 msg = xyzfCloud(header, scan.size(), "i");
  fillXyzf(
      scan, "i",
      [](const LidarPoint& p, float* x, float* y, float* z, float* i) {
        *x = p.x, *y = p.y, *z = p.z, *i = p.intensity;
      },
      &msg);
  return msg;
}

visualization_msgs::Marker toMeshMarker(const LidarMesh& mesh, const std_msgs::Header& header,
                                        size_t max_faces, double max_range) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = "lidar_mesh";
  m.id = 0;
  m.type = visualization_msgs::Marker::TRIANGLE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = m.scale.z = 1.0;
  m.color.a = 1.0;
  const size_t n = mesh.faces.size();
  const size_t step = max_faces > 0 && n > max_faces ? (n + max_faces - 1) / max_faces : 1;
  m.points.reserve(3 * (n / step + 1));
  m.colors.reserve(3 * (n / step + 1));
  for (size_t i = 0; i < n; i += step) {
    const MeshFace& f = mesh.faces[i];
    std_msgs::ColorRGBA c;
    const double t = std::min(1.0, std::max(0.0, f.range / max_range));
    c.r = static_cast<float>(1.0 - t);
    c.g = static_cast<float>(1.0 - std::fabs(2.0 * t - 1.0));
    c.b = static_cast<float>(t);
    c.a = 0.8f;
    for (const Eigen::Vector3f* v : {&f.a, &f.b, &f.c}) {
      geometry_msgs::Point p;
      p.x = v->x(), p.y = v->y(), p.z = v->z();
      m.points.push_back(p);
      m.colors.push_back(c);
    }
  }
  return m;
}

namespace {
const sensor_msgs::PointField* findField(const sensor_msgs::PointCloud2& msg,
                                         const std::string& n) {
  for (const auto& f : msg.fields)
    if (f.name == n) return &f;
  return nullptr;
}

/// Bytes of one value of a PointField datatype; 0 for an unknown one.
size_t datatypeSize(uint8_t datatype) {
  switch (datatype) {
    case sensor_msgs::PointField::INT8:
    case sensor_msgs::PointField::UINT8:
      return 1;
    case sensor_msgs::PointField::INT16:
    case sensor_msgs::PointField::UINT16:
      return 2;
    case sensor_msgs::PointField::INT32:
    case sensor_msgs::PointField::UINT32:
    case sensor_msgs::PointField::FLOAT32:
      return 4;
    case sensor_msgs::PointField::FLOAT64:
      return 8;
    default:
      return 0;
  }
}

/// Empty when field `f` (one the reader uses) lies within a point of `point_step` bytes; else
/// why not. A driver's or a bag's broken layout must be a message, not a read past the buffer.
std::string fieldProblem(const sensor_msgs::PointField& f, uint32_t point_step) {
  const size_t size = datatypeSize(f.datatype);
  if (size == 0)
    return "point cloud field '" + f.name + "' has an unknown datatype (" +
           std::to_string(f.datatype) + ")";
  if (static_cast<size_t>(f.offset) + size > point_step)
    return "point cloud field '" + f.name + "' (offset " + std::to_string(f.offset) + ", " +
           std::to_string(size) + " bytes) does not fit in a point of point_step " +
           std::to_string(point_step) + " bytes";
  return "";
}

double readScalar(const uint8_t* data, uint8_t datatype) {
  switch (datatype) {
    case sensor_msgs::PointField::FLOAT32: {
      float v;
      std::memcpy(&v, data, 4);
      return v;
    }
    case sensor_msgs::PointField::FLOAT64: {
      double v;
      std::memcpy(&v, data, 8);
      return v;
    }
    case sensor_msgs::PointField::UINT8:
      return *data;
    case sensor_msgs::PointField::INT8:
      return static_cast<int8_t>(*data);
    case sensor_msgs::PointField::UINT16: {
      uint16_t v;
      std::memcpy(&v, data, 2);
      return v;
    }
    case sensor_msgs::PointField::INT16: {
      int16_t v;
      std::memcpy(&v, data, 2);
      return v;
    }
    case sensor_msgs::PointField::UINT32: {
      uint32_t v;
      std::memcpy(&v, data, 4);
      return v;
    }
    case sensor_msgs::PointField::INT32: {
      int32_t v;
      std::memcpy(&v, data, 4);
      return v;
    }
    default:
      return std::nan("");
  }
}
/// A per-point time as seconds from the cloud's stamp: integer "t" (Ouster) is nanoseconds,
/// values beyond 1e6 are absolute stamps (Hesai, Livox), others seconds from the stamp
/// (velodyne_pointcloud's "time").
double secondsFromStamp(double v, const sensor_msgs::PointField& f, double stamp) {
  if (f.name == "t" && f.datatype != sensor_msgs::PointField::FLOAT32 &&
      f.datatype != sensor_msgs::PointField::FLOAT64)
    return v * 1e-9;
  return v > 1e6 ? v - stamp : v;
}
}  // namespace

std::string perPointTimeField(const sensor_msgs::PointCloud2& msg) {
  for (const char* name : {"time", "t", "timestamp", "time_stamp"})
    if (findField(msg, name)) return name;
  return "";
}

bool fromPointCloud2(const sensor_msgs::PointCloud2& msg, LidarScan* scan, std::string* error,
                     bool* ring_recovered) {
  scan->clear();
  if (ring_recovered) *ring_recovered = false;
  const auto* fx = findField(msg, "x");
  const auto* fy = findField(msg, "y");
  const auto* fz = findField(msg, "z");
  if (!fx || !fy || !fz) {
    *error = "point cloud has no x/y/z fields";
    return false;
  }
  if (msg.is_bigendian) {
    *error = "big-endian point clouds are not supported";
    return false;
  }
  const size_t n = static_cast<size_t>(msg.width) * msg.height;
  if (n == 0) {
    *error = "point cloud is empty";
    return false;
  }
  // The layout: rows of row_step bytes, each holding width points of point_step bytes.
  // A single row's row_step is not needed: some hand-made clouds leave it 0.
  const size_t row_bytes = static_cast<size_t>(msg.width) * msg.point_step;
  const size_t row_step = msg.height == 1 ? row_bytes : msg.row_step;
  if (msg.point_step == 0 || row_step < row_bytes ||
      msg.data.size() < static_cast<size_t>(msg.height - 1) * row_step + row_bytes) {
    *error = "point cloud layout is inconsistent (width " + std::to_string(msg.width) +
             ", height " + std::to_string(msg.height) + ", point_step " +
             std::to_string(msg.point_step) + ", row_step " + std::to_string(msg.row_step) + ", " +
             std::to_string(msg.data.size()) + " bytes of data)";
    return false;
  }
  const auto* fi = findField(msg, "intensity");
  if (!fi) fi = findField(msg, "i");  // kitti2bag's name
  const auto* fr = findField(msg, "ring");
  const std::string time_name = perPointTimeField(msg);
  const auto* ft = time_name.empty() ? nullptr : findField(msg, time_name);
  for (const auto* f : {fx, fy, fz, fi, fr, ft}) {
    if (!f) continue;
    const std::string problem = fieldProblem(*f, msg.point_step);
    if (!problem.empty()) {
      *error = problem;
      return false;
    }
  }
  const double stamp = msg.header.stamp.toSec();
  scan->reserve(n);
  size_t dropped = 0;
  for (size_t k = 0; k < n; ++k) {
    const uint8_t* p =
        msg.data.data() + (k / msg.width) * row_step + (k % msg.width) * msg.point_step;
    LidarPoint q;
    q.x = static_cast<float>(readScalar(p + fx->offset, fx->datatype));
    q.y = static_cast<float>(readScalar(p + fy->offset, fy->datatype));
    q.z = static_cast<float>(readScalar(p + fz->offset, fz->datatype));
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) ||
        (q.x == 0.f && q.y == 0.f && q.z == 0.f)) {
      ++dropped;
      continue;
    }
    q.intensity = fi ? static_cast<float>(readScalar(p + fi->offset, fi->datatype)) : 0.f;
    q.ring = fr ? static_cast<uint16_t>(readScalar(p + fr->offset, fr->datatype)) : 0;
    if (ft)
      q.time = static_cast<float>(
          secondsFromStamp(readScalar(p + ft->offset, ft->datatype), *ft, stamp));
    scan->push_back(q);
  }
  if (scan->empty()) {
    *error = "point cloud has no finite points (" + std::to_string(dropped) + " dropped)";
    return false;
  }
  if (!fr) {
    recoverRings(*scan);
    if (ring_recovered) *ring_recovered = true;
  }
  return true;
}

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
