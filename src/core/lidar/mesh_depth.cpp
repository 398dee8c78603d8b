#include "tescalib/core/lidar/mesh_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tescalib/core/common/pinhole.h"

namespace tescalib {

MeshDepth renderMeshDepth(const LidarMesh& mesh, const Eigen::Isometry3d& T,
                          const CameraIntrinsics& cam) {
  MeshDepth out;
  out.depth =
      cv::Mat(cam.height, cam.width, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  out.face_id = cv::Mat(cam.height, cam.width, CV_32S, cv::Scalar(-1));
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float fx = float(cam.fx), fy = float(cam.fy), cx = float(cam.cx), cy = float(cam.cy);
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const MeshFace& f = mesh.faces[i];
    const Eigen::Vector3f a = R * f.a + t, b = R * f.b + t, c = R * f.c + t;
    if (a.z() < 0.5f || b.z() < 0.5f || c.z() < 0.5f) continue;
    const Eigen::Vector2f pa = projectPinhole(fx, fy, cx, cy, a);
    const Eigen::Vector2f pb = projectPinhole(fx, fy, cx, cy, b);
    const Eigen::Vector2f pc = projectPinhole(fx, fy, cx, cy, c);
    const int u0 = std::max(0, int(std::floor(std::min({pa.x(), pb.x(), pc.x()}))));
    const int u1 = std::min(cam.width - 1, int(std::ceil(std::max({pa.x(), pb.x(), pc.x()}))));
    const int v0 = std::max(0, int(std::floor(std::min({pa.y(), pb.y(), pc.y()}))));
    const int v1 = std::min(cam.height - 1, int(std::ceil(std::max({pa.y(), pb.y(), pc.y()}))));
    if (u0 > u1 || v0 > v1 || (u1 - u0) * (v1 - v0) > 4000) continue;
    const float area =
        (pb.x() - pa.x()) * (pc.y() - pa.y()) - (pc.x() - pa.x()) * (pb.y() - pa.y());
    if (std::fabs(area) < 1e-6f) continue;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const float px = u + 0.0f, py = v + 0.0f;
        const float w0 = ((pb.x() - px) * (pc.y() - py) - (pc.x() - px) * (pb.y() - py)) / area;
        const float w1 = ((pc.x() - px) * (pa.y() - py) - (pa.x() - px) * (pc.y() - py)) / area;
        const float w2 = 1.f - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        // Perspective-correct depth: 1/z is affine in the image.
        const float z = 1.f / (w0 / a.z() + w1 / b.z() + w2 / c.z());
        float& d = out.depth.at<float>(v, u);
        if (z < d) d = z, out.face_id.at<int>(v, u) = int(i);
      }
    }
  }
  return out;
}

bool intersectFace(const MeshFace& f, const Eigen::Isometry3d& T, const CameraIntrinsics& cam,
                   double u, double v, Eigen::Vector3d* X) {
  // The face's own plane (not the smoothed normal): points on it are barycentric combinations of
  // its vertices, paper eq. parametric_equation.
  const Eigen::Vector3d a = T * f.a.cast<double>(), b = T * f.b.cast<double>();
  const Eigen::Vector3d p0 = T * f.c.cast<double>();
  const Eigen::Vector3d n = (b - a).cross(p0 - a);
  const Eigen::Vector3d ray = cam.ray(u, v);
  const double den = n.dot(ray);
  if (std::fabs(den) < 1e-9) return false;
  const double z = n.dot(p0) / den;
  if (z <= 0) return false;
  *X = z * ray;
  return true;
}

Visibility visibility(const Eigen::Vector3d& Y, const CameraIntrinsics& cam, const MeshDepth& md,
                      double tolerance) {
  if (!(Y.z() > 0)) return Visibility::kOutside;
  const Eigen::Vector2d px = cam.project(Y);
  const int iu = int(std::lround(px.x()));
  const int iv = int(std::lround(px.y()));
  if (iu < 0 || iv < 0 || iu >= cam.width || iv >= cam.height) return Visibility::kOutside;
  return Y.z() > md.depth.at<float>(iv, iu) * (1.0 + tolerance) ? Visibility::kOccluded
                                                                : Visibility::kVisible;
}

}  // namespace tescalib
