// Surface appearance of the generated scenes: procedural textures defined on the surfaces in
// world (or object) coordinates, so both cameras and every frame see the same texture, plus the
// LiDAR reflectivity of each material. Every pattern is filtered by the pixel footprint.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "tescalib/core/sim/scene_primitive.h"
#include "tescalib/core/sim/scene_road.h"

namespace tescalib {
namespace sim {

/// A visible surface point as the texture functions need it.
struct SurfacePoint {
  Eigen::Vector3f world = Eigen::Vector3f::Zero();    ///< position (m)
  Eigen::Vector3f local = Eigen::Vector3f::Zero();    ///< position in the primitive's frame
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  ///< world unit normal
  uint8_t face = 0;                                   ///< Face of the primitive
  Eigen::Vector3f dpdx = Eigen::Vector3f::Zero();     ///< surface step per pixel step in x (m)
  Eigen::Vector3f dpdy = Eigen::Vector3f::Zero();     ///< surface step per pixel step in y (m)

  /// Pixel footprint along a unit world direction (m).
  float footprintAlong(const Eigen::Vector3f& axis) const {
    return std::abs(dpdx.dot(axis)) + std::abs(dpdy.dot(axis));
  }
  /// Filter width for isotropic noise (m): the footprint along image rows, and along columns up
  /// to twice that. Rows are the epipolar lines: detail finer than a pixel along them would differ
  /// between the two views, while finer detail across them (the road far ahead, stretched
  /// vertically) only shows as grain that both views share.
  float footprint() const {
    const float x = dpdx.norm();
    return std::max(x, std::min(dpdy.norm(), 2.f * x));
  }
};

/// What a surface point looks like.
struct SurfaceLook {
  Eigen::Vector3f albedo = Eigen::Vector3f::Constant(0.5f);  ///< diffuse RGB albedo, 0..1
  float reflectivity = 0.3f;                                 ///< LiDAR reflectance, 0..1
};

/// Texture of a primitive at a surface point.
SurfaceLook shadePrimitive(const Primitive& p, const SurfacePoint& sp);

/// Texture of the ground plane at a surface point (lane markings, asphalt, grass, ...).
SurfaceLook shadeGround(const RoadPath& road, const GroundLayout& layout, const SurfacePoint& sp,
                        uint32_t seed);

}  // namespace sim
}  // namespace tescalib
