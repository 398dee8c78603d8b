#include "tescalib/core/sim/scene_primitive.h"

#include <algorithm>
#include <cmath>

namespace tescalib {
namespace sim {
namespace {

constexpr float kParallel = 1e-12f;

/// Clips [t0, t1] by the half-space n.p <= e (local frame); tracks the entering plane's face.
bool clipHalfSpace(const Eigen::Vector3f& n, float e, const Eigen::Vector3f& o,
                   const Eigen::Vector3f& d, uint8_t face, float* t0, float* t1, int* entry_face,
                   Eigen::Vector3f* entry_normal) {
  const float denom = n.dot(d);
  const float dist = e - n.dot(o);
  if (std::fabs(denom) < kParallel) return dist >= 0.f;
  const float t = dist / denom;
  if (denom < 0.f) {  // entering
    if (t > *t0) {
      *t0 = t;
      *entry_face = face;
      *entry_normal = n;
    }
  } else if (t < *t1) {
    *t1 = t;
  }
  return *t0 <= *t1;
}

bool intersectBox(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                  float tmin, float tmax, PrimitiveHit* hit) {
  float t0 = -1e30f, t1 = tmax;
  int face = -1;
  const float lo[3] = {-p.hx, -p.hy, p.z0};
  const float hi[3] = {p.hx, p.hy, p.z1};
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < kParallel) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    const float inv = 1.f / d[a];
    float ta = (lo[a] - o[a]) * inv, tb = (hi[a] - o[a]) * inv;
    // Entering through the low plane when moving up the axis: that is the negative face.
    int fa = 2 * a + 1;
    if (ta > tb) {
      std::swap(ta, tb);
      fa = 2 * a;
    }
    if (ta > t0) {
      t0 = ta;
      face = fa;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  if (face < 0 || t0 <= tmin || t0 >= tmax) return false;
  hit->t = t0;
  hit->face = static_cast<uint8_t>(face);
  const int axis = face / 2;
  hit->normal_local = Eigen::Vector3f::Zero();
  hit->normal_local[axis] = (face % 2 == 0) ? 1.f : -1.f;
  return true;
}

bool intersectCylinder(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                       float tmin, float tmax, PrimitiveHit* hit) {
  const float r = p.hx;
  float best = tmax;
  bool found = false;
  const float a = d.x() * d.x() + d.y() * d.y();
  if (a > kParallel) {
    const float b = o.x() * d.x() + o.y() * d.y();
    const float c = o.x() * o.x() + o.y() * o.y() - r * r;
    const float disc = b * b - a * c;
    if (disc >= 0.f) {
      const float t = (-b - std::sqrt(disc)) / a;
      const float z = o.z() + t * d.z();
      if (t > tmin && t < best && z >= p.z0 && z <= p.z1 && c > 0.f) {
        best = t;
        found = true;
        hit->face = kFacePosX;
        hit->normal_local = Eigen::Vector3f(o.x() + t * d.x(), o.y() + t * d.y(), 0.f) / r;
      }
    }
  }
  if (std::fabs(d.z()) > kParallel) {
    const bool from_above = o.z() > p.z1 && d.z() < 0.f;
    const bool from_below = o.z() < p.z0 && d.z() > 0.f;
    if (from_above || from_below) {
      const float zc = from_above ? p.z1 : p.z0;
      const float t = (zc - o.z()) / d.z();
      const float x = o.x() + t * d.x(), y = o.y() + t * d.y();
      if (t > tmin && t < best && x * x + y * y <= r * r) {
        best = t;
        found = true;
        hit->face = from_above ? kFaceTop : kFaceBottom;
        hit->normal_local = Eigen::Vector3f(0.f, 0.f, from_above ? 1.f : -1.f);
      }
    }
  }
  if (found) hit->t = best;
  return found;
}

bool intersectEllipsoid(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                        float tmin, float tmax, PrimitiveHit* hit) {
  const float rz = 0.5f * (p.z1 - p.z0), zc = 0.5f * (p.z0 + p.z1);
  const Eigen::Vector3f os(o.x() / p.hx, o.y() / p.hy, (o.z() - zc) / rz);
  const Eigen::Vector3f ds(d.x() / p.hx, d.y() / p.hy, d.z() / rz);
  const float a = ds.squaredNorm();
  const float b = os.dot(ds);
  const float c = os.squaredNorm() - 1.f;
  if (c <= 0.f) return false;  // starts inside
  const float disc = b * b - a * c;
  if (disc < 0.f) return false;
  const float t = (-b - std::sqrt(disc)) / a;
  if (t <= tmin || t >= tmax) return false;
  const Eigen::Vector3f q = os + t * ds;  // on the unit sphere
  hit->t = t;
  hit->face = kFacePosX;
  hit->normal_local = Eigen::Vector3f(q.x() / p.hx, q.y() / p.hy, q.z() / rz).normalized();
  return true;
}

bool intersectGable(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                    float tmin, float tmax, PrimitiveHit* hit) {
  const float k = (p.z1 - p.z0) / p.hy;  // roof slope
  const float norm = std::sqrt(1.f + k * k);
  float t0 = -1e30f, t1 = tmax;
  int face = -1;
  Eigen::Vector3f n = Eigen::Vector3f::UnitZ();
  if (!clipHalfSpace(Eigen::Vector3f::UnitX(), p.hx, o, d, kFacePosX, &t0, &t1, &face, &n) ||
      !clipHalfSpace(-Eigen::Vector3f::UnitX(), p.hx, o, d, kFaceNegX, &t0, &t1, &face, &n) ||
      !clipHalfSpace(-Eigen::Vector3f::UnitZ(), -p.z0, o, d, kFaceBottom, &t0, &t1, &face, &n) ||
      !clipHalfSpace(Eigen::Vector3f(0.f, k, 1.f) / norm, p.z1 / norm, o, d, kFacePosY, &t0, &t1,
                     &face, &n) ||
      !clipHalfSpace(Eigen::Vector3f(0.f, -k, 1.f) / norm, p.z1 / norm, o, d, kFaceNegY, &t0, &t1,
                     &face, &n))
    return false;
  if (face < 0 || t0 <= tmin || t0 >= tmax) return false;
  hit->t = t0;
  hit->face = static_cast<uint8_t>(face);
  hit->normal_local = n;
  return true;
}

}  // namespace

bool intersectPrimitive(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                        float tmin, float tmax, PrimitiveHit* hit) {
  const Eigen::Vector3f ol = toLocal(p, o);
  const Eigen::Vector3f dl(p.cos_yaw * d.x() + p.sin_yaw * d.y(),
                           -p.sin_yaw * d.x() + p.cos_yaw * d.y(), d.z());
  switch (p.shape) {
    case Shape::kBox:
      return intersectBox(p, ol, dl, tmin, tmax, hit);
    case Shape::kCylinder:
      return intersectCylinder(p, ol, dl, tmin, tmax, hit);
    case Shape::kEllipsoid:
      return intersectEllipsoid(p, ol, dl, tmin, tmax, hit);
    case Shape::kGable:
      return intersectGable(p, ol, dl, tmin, tmax, hit);
  }
  return false;
}

float distanceToBounds(const Primitive& p, const Eigen::Vector3f& point) {
  const Eigen::Vector3f l = toLocal(p, point);
  const float dx = std::max(std::fabs(l.x()) - p.hx, 0.f);
  const float dy = std::max(std::fabs(l.y()) - p.hy, 0.f);
  const float dz = std::max(std::max(p.z0 - l.z(), l.z() - p.z1), 0.f);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

void boundsCorners(const Primitive& p, Eigen::Vector3f corners[8]) {
  int k = 0;
  for (int iz = 0; iz < 2; ++iz)
    for (int iy = -1; iy <= 1; iy += 2)
      for (int ix = -1; ix <= 1; ix += 2)
        corners[k++] =
            Eigen::Vector3f(p.cx + p.cos_yaw * ix * p.hx - p.sin_yaw * iy * p.hy,
                            p.cy + p.sin_yaw * ix * p.hx + p.cos_yaw * iy * p.hy, iz ? p.z1 : p.z0);
}

}  // namespace sim
}  // namespace tescalib
