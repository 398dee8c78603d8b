// The analytic solids the generated scenes are made of: boxes, vertical cylinders, ellipsoids and
// gable roofs, each standing upright (yaw only) in a world whose ground is the plane z = 0.
// Ray intersection is exact, so LiDAR ranges and rendered depths agree to float precision.
#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace tescalib {
namespace sim {

enum class Shape : uint8_t {
  kBox,        ///< |x| <= hx, |y| <= hy, z0 <= z <= z1 (local frame)
  kCylinder,   ///< vertical, radius hx, z0 <= z <= z1
  kEllipsoid,  ///< radii hx, hy, (z1 - z0) / 2, centred at (z0 + z1) / 2
  kGable,      ///< prism: ridge along local x at z1, eaves at z0 and |y| = hy
};

/// Appearance of a primitive; scene_material.cpp turns it into a texture.
enum class Material : uint8_t {
  kBrickFacade,    ///< brick wall with a window grid (param: floor height, window w, h, pitch)
  kPlasterFacade,  ///< plaster wall with a window grid (same params)
  kHouseWall,      ///< siding boards, one window row per floor (same params)
  kTileRoof,       ///< tiled slopes; the gable ends use color2
  kCurb,           ///< granite curb stone
  kCarBody,        ///< paint, bumpers, lights, door seams (param[0] > 0: front at +x)
  kCarCabin,       ///< glass with pillars in the paint colour
  kTire,           ///< rubber with a rim on the outer face
  kBark,           ///< tree trunk
  kFoliage,        ///< tree crown or bush
  kHedge,          ///< dense clipped leaves
  kMetal,          ///< poles, lamp heads
  kSign,           ///< sign plate, colour with white border (param[0] > 0: face at +y)
  kGuardRail,      ///< galvanised W-beam
  kConcrete,       ///< posts, walls, barriers
  kFence,          ///< wooden picket fence
};

/// One solid. Local frame: origin at (cx, cy, 0), x axis along (cos_yaw, sin_yaw), z up.
struct Primitive {
  Shape shape = Shape::kBox;                ///< geometry type
  Material material = Material::kConcrete;  ///< appearance
  uint32_t style = 0;                       ///< per-object seed of its texture details
  float cx = 0.f;                           ///< footprint centre, world x (m)
  float cy = 0.f;                           ///< footprint centre, world y (m)
  float cos_yaw = 1.f;                      ///< world x component of the local x axis
  float sin_yaw = 0.f;                      ///< world y component of the local x axis
  float hx = 0.f;                           ///< half extent (radius) along local x (m)
  float hy = 0.f;                           ///< half extent (radius) along local y (m)
  float z0 = 0.f;                           ///< bottom (m)
  float z1 = 0.f;                           ///< top (m)
  float color[3] = {0.5f, 0.5f, 0.5f};      ///< main albedo, RGB in 0..1
  float color2[3] = {0.8f, 0.8f, 0.8f};     ///< secondary albedo (frames, trim, gable ends)
  float param[4] = {0.f, 0.f, 0.f, 0.f};    ///< material parameters
};

/// Face indices reported by intersectPrimitive (box: all six; other shapes use a subset).
enum Face : uint8_t { kFacePosX, kFaceNegX, kFacePosY, kFaceNegY, kFaceTop, kFaceBottom };

/// Where a ray meets a primitive.
struct PrimitiveHit {
  float t = 0.f;     ///< ray parameter (m for unit directions)
  uint8_t face = 0;  ///< Face of the hit
  Eigen::Vector3f normal_local = Eigen::Vector3f::UnitZ();  ///< outward unit normal, local frame
};

/// Nearest intersection of the ray o + t d with t in (tmin, tmax). A ray starting inside the
/// solid does not hit it.
bool intersectPrimitive(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                        float tmin, float tmax, PrimitiveHit* hit);

/// Distance from a point to the primitive's bounding box (a lower bound of any hit distance).
float distanceToBounds(const Primitive& p, const Eigen::Vector3f& point);

/// The eight corners of the bounding box, world frame.
void boundsCorners(const Primitive& p, Eigen::Vector3f corners[8]);

/// World point -> local frame, and local direction -> world.
inline Eigen::Vector3f toLocal(const Primitive& p, const Eigen::Vector3f& w) {
  const float dx = w.x() - p.cx, dy = w.y() - p.cy;
  return {p.cos_yaw * dx + p.sin_yaw * dy, -p.sin_yaw * dx + p.cos_yaw * dy, w.z()};
}
inline Eigen::Vector3f localDirToWorld(const Primitive& p, const Eigen::Vector3f& l) {
  return {p.cos_yaw * l.x() - p.sin_yaw * l.y(), p.sin_yaw * l.x() + p.cos_yaw * l.y(), l.z()};
}

}  // namespace sim
}  // namespace tescalib
