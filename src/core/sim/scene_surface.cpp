#include "tescalib/core/sim/scene_surface.h"

namespace tescalib {
namespace sim {

SurfacePoint surfaceAt(const SceneWorld& world, const TraceResult& hit, const Eigen::Vector3f& o,
                       const Eigen::Vector3f& d) {
  SurfacePoint sp;
  sp.world = o + hit.t * d;
  if (hit.prim == TraceResult::kGround) {
    sp.world.z() = 0.f;
    sp.local = sp.world;
    sp.normal = Eigen::Vector3f::UnitZ();
    sp.face = kFaceTop;
    return sp;
  }
  const Primitive& p = world.prims[static_cast<size_t>(hit.prim)];
  sp.local = toLocal(p, sp.world);
  sp.normal = localDirToWorld(p, hit.hit.normal_local);
  sp.face = hit.hit.face;
  return sp;
}

SurfaceLook lookAt(const SceneWorld& world, const TraceResult& hit, const SurfacePoint& sp) {
  if (hit.prim == TraceResult::kGround)
    return shadeGround(*world.road, world.ground, sp, world.texture_seed);
  return shadePrimitive(world.prims[static_cast<size_t>(hit.prim)], sp);
}

}  // namespace sim
}  // namespace tescalib
