// Generates the static world of a driving scenario along a road, deterministically from a seed:
// what stands where (buildings, cars, trees, poles, rails), the road's curves and ground layout,
// the sun, and the lane the vehicle drives in.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tescalib/core/sim/scene_primitive.h"
#include "tescalib/core/sim/scene_road.h"

namespace tescalib {
namespace sim {

/// The driving scenarios of tescalib_simulate.
enum class Scenario {
  kUrban,        ///< street canyon: facades on both sides, parked cars, poles, trees
  kResidential,  ///< low houses with gaps, hedges, fences, gardens, trees
  kHighway,      ///< wide flat road with guard rails; hardly any vertical structure
};

/// "urban" | "residential" | "highway".
std::string scenarioName(Scenario s);
/// Parses a scenario name; returns false on an unknown name.
bool parseScenario(const std::string& name, Scenario* s);

/// A generated world.
struct SceneWorld {
  Scenario scenario = Scenario::kUrban;            ///< what was generated
  std::unique_ptr<RoadPath> road;                  ///< centreline and road frame
  GroundLayout ground;                             ///< ground bands and lane markings
  std::vector<Primitive> prims;                    ///< every solid
  Eigen::Vector3f sun = Eigen::Vector3f::UnitZ();  ///< unit vector towards the sun (world)
  float lane_offset = -1.75f;                      ///< lateral offset of the driven lane (m)
  uint32_t texture_seed = 0;                       ///< seed of the ground textures
};

/// Builds the world of `scenario` for stations [s_min, s_max] (m) along the road. Objects are
/// generated in 60 m chunks, each from its own sub-seed of `seed`, so the world along a given
/// stretch does not depend on how far the road extends.
SceneWorld buildScene(Scenario scenario, uint64_t seed, double s_min, double s_max);

}  // namespace sim
}  // namespace tescalib
