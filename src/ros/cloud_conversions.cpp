#include "tescalib/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <sensor_msgs/point_cloud2_iterator.h>

#include "tescalib/core/io/velodyne_bin.h"

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

}  // namespace ros_conv
}  // namespace tescalib
