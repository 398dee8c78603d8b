// The road of a generated scene: a smooth centreline with gentle curves in the ground plane, the
// road frame (station s along it, lateral offset l to the left) and the layout of the ground
// across it (asphalt, grass, gravel bands and lane markings).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace tescalib {
namespace sim {

/// Heading of the centreline as a function of the station: a sum of slow sinusoids, so the
/// curvature (its derivative) stays small and the road never drifts sideways for good.
struct RoadCurves {
  double amplitude[2] = {0.0, 0.0};   ///< heading amplitudes (rad)
  double length[2] = {400.0, 200.0};  ///< periods along the road (m)
  double phase[2] = {0.0, 0.0};       ///< phases (rad)

  double heading(double s) const;
  double curvature(double s) const;  ///< 1/m, d heading / ds
};

/// The centreline, sampled every `step` metres, with a lookup grid for world -> road coordinates.
class RoadPath {
 public:
  /// Integrates the centreline from s_min to s_max; position (0, 0) at s = 0. World -> road
  /// lookups are answered within `corridor` metres of the centreline.
  RoadPath(const RoadCurves& curves, double s_min, double s_max, double corridor = 70.0);

  double sMin() const { return s_min_; }
  double sMax() const { return s_max_; }
  const RoadCurves& curves() const { return curves_; }

  /// Centreline point at station s (linear between samples).
  Eigen::Vector2d point(double s) const;
  /// Heading of the centreline at s (rad, from the world x axis).
  double heading(double s) const { return curves_.heading(s); }
  /// World point at road coordinates (s, l); l > 0 is left of the driving direction.
  Eigen::Vector2d toWorld(double s, double l) const;

  /// World (x, y) -> road coordinates. Returns false farther than the corridor from the road.
  /// `tangent` receives the unit direction of the road there (may be null).
  bool toRoad(float x, float y, float* s, float* l, Eigen::Vector2f* tangent) const;

 private:
  RoadCurves curves_;
  double s_min_, s_max_, step_;
  std::vector<Eigen::Vector2d> points_;  ///< centreline samples
  std::vector<Eigen::Vector2f> tangents_;
  // Lookup grid: for each cell, a nearby centreline sample (or -1 outside the corridor).
  double grid_x0_ = 0, grid_y0_ = 0, cell_ = 2.0;
  int grid_w_ = 0, grid_h_ = 0;
  std::vector<int32_t> grid_;
  float corridor_;
};

/// Ground surfaces of the plane z = 0.
enum class GroundSurface : uint8_t { kAsphalt, kPaving, kGrass, kGravel, kCobble, kField };

/// A band of the ground between two lateral offsets.
struct GroundBand {
  float l0 = 0.f;                                   ///< right edge (m, road frame)
  float l1 = 0.f;                                   ///< left edge (m)
  GroundSurface surface = GroundSurface::kAsphalt;  ///< what it is made of
};

/// A painted line along the road.
struct LaneMarking {
  float l = 0.f;        ///< lateral position of its centre (m)
  float width = 0.12f;  ///< m
  float dash = 0.f;     ///< dash length (m); 0 = solid
  float gap = 0.f;      ///< gap between dashes (m)
};

/// What the ground looks like across the road; everything else is `outside`.
struct GroundLayout {
  std::vector<GroundBand> bands;                  ///< lateral bands, any order
  std::vector<LaneMarking> markings;              ///< painted lines (on asphalt)
  GroundSurface outside = GroundSurface::kField;  ///< beyond the bands and the corridor
  float asphalt_texture = 1.f;                    ///< contrast of the asphalt's patches and grain
};

}  // namespace sim
}  // namespace tescalib
