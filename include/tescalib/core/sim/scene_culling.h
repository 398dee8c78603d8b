// Ray casting acceleration for the scene generator. Rays of one sensor share an origin (camera,
// LiDAR) or a direction (sun), so each primitive is binned once per frame by where its bounding
// box projects: image tiles for a pinhole camera, azimuth sectors for the spinning LiDAR, a grid
// across the sun direction for shadows. A ray then tests only its bin's primitives, nearest bound
// first, and stops as soon as the next bound lies beyond its current hit.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "tescalib/core/sim/scene_primitive.h"

namespace tescalib {
namespace sim {

/// A primitive that a ray of a bin may hit, with a lower bound of the hit distance.
struct Candidate {
  uint32_t prim = 0;     ///< index into the primitive list
  float min_dist = 0.f;  ///< distance from the ray origin to the primitive's bounding box (m)
};

/// Candidate lists of a 2D array of bins, each sorted by min_dist.
class TileCandidates {
 public:
  TileCandidates(int tiles_x = 1, int tiles_y = 1);

  int tilesX() const { return tiles_x_; }
  int tilesY() const { return tiles_y_; }
  /// Adds a candidate to the bins [tx0, tx1] x [ty0, ty1] (clamped to the array).
  void add(uint32_t prim, float min_dist, int tx0, int tx1, int ty0, int ty1);
  /// Sorts and packs the lists; call once after the last add().
  void finalize();

  const Candidate* begin(int tx, int ty) const { return items_.data() + offsets_[index(tx, ty)]; }
  const Candidate* end(int tx, int ty) const { return items_.data() + offsets_[index(tx, ty) + 1]; }

 private:
  size_t index(int tx, int ty) const { return static_cast<size_t>(ty) * tiles_x_ + tx; }

  struct Pending {
    uint32_t bin;  ///< bin index
    Candidate c;   ///< what goes into it
  };
  int tiles_x_, tiles_y_;
  std::vector<Pending> pending_;
  std::vector<uint32_t> offsets_;
  std::vector<Candidate> items_;
};

/// A pinhole camera looking into the world.
struct PinholeView {
  Eigen::Matrix3f R_cam_world = Eigen::Matrix3f::Identity();  ///< world -> camera rotation
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();           ///< camera centre, world (m)
  float fx = 1.f, fy = 1.f, cx = 0.f, cy = 0.f;               ///< intrinsics (px)
  int width = 0, height = 0;                                  ///< image size (px)
};

/// Bins the primitives within `max_range` by the image tiles (tile x tile px) their bounding
/// boxes cover, with a one-pixel margin for sub-pixel samples.
TileCandidates cullPinhole(const std::vector<Primitive>& prims, const PinholeView& view,
                           float max_range, int tile);

/// Bins the primitives within `max_range` by the azimuth sectors (of `bins` around the sensor's
/// z axis, azimuth atan2(y, x) in [0, 2 pi)) their bounding boxes cover, one sector of margin.
TileCandidates cullSpinning(const std::vector<Primitive>& prims,
                            const Eigen::Matrix3f& R_sensor_world, const Eigen::Vector3f& origin,
                            float max_range, int bins);

/// Azimuth sector of a direction in the sensor frame, as used by cullSpinning().
int azimuthBin(const Eigen::Vector3f& dir_sensor, int bins);

/// Nearest hit of a ray among candidates and the ground plane z = 0.
struct TraceResult {
  float t = 0.f;      ///< hit distance (m; directions are unit vectors)
  int prim = kNoHit;  ///< primitive index, kGround or kNoHit
  PrimitiveHit hit;   ///< face and local normal (primitives only)

  static constexpr int kGround = -1;
  static constexpr int kNoHit = -2;
};

/// Casts o + t d (d unit) against the candidates [begin, end) and the ground, up to tmax.
TraceResult traceRay(const std::vector<Primitive>& prims, const Candidate* begin,
                     const Candidate* end, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                     float tmax);

/// Shadow test for a fixed sun direction: primitives near the vehicle binned on a grid across
/// the sun direction.
class SunShadowGrid {
 public:
  /// `sun` points towards the sun (unit). Primitives within `radius` of `centre` cast shadows.
  SunShadowGrid(const std::vector<Primitive>& prims, const Eigen::Vector3f& sun,
                const Eigen::Vector3f& centre, float radius, float cell = 2.f);

  /// True when nothing blocks the sun from p (p already lifted off its surface).
  bool sunlit(const Eigen::Vector3f& p) const;

 private:
  const std::vector<Primitive>* prims_;
  Eigen::Vector3f sun_, e1_, e2_;
  float a0_ = 0.f, b0_ = 0.f, cell_;
  int w_ = 0, h_ = 0;
  std::vector<uint32_t> offsets_;
  std::vector<uint32_t> items_;
  std::vector<float> item_top_;  ///< highest point of each item's box along the sun direction
};

}  // namespace sim
}  // namespace tescalib
