// What a sensor ray hit in a generated world: the surface point (position, normal, local
// coordinates) and its look (albedo, LiDAR reflectivity). Shared by the cameras and the LiDAR so
// both see the same surfaces.
#pragma once

#include <Eigen/Core>

#include "tescalib/core/sim/scene_builder.h"
#include "tescalib/core/sim/scene_culling.h"
#include "tescalib/core/sim/scene_material.h"

namespace tescalib {
namespace sim {

/// Surface point of a hit (prim or ground) of the ray o + t d; the footprint is left zero.
SurfacePoint surfaceAt(const SceneWorld& world, const TraceResult& hit, const Eigen::Vector3f& o,
                       const Eigen::Vector3f& d);

/// Look of a hit surface point (the footprint of `sp` filters the texture).
SurfaceLook lookAt(const SceneWorld& world, const TraceResult& hit, const SurfacePoint& sp);

}  // namespace sim
}  // namespace tescalib
