// The vehicle's motion through a generated scene: it follows its lane at 8-14 m/s (a slow speed
// oscillation), with a little lateral wander, yaw, pitch and roll as a real car has.
#pragma once

#include <cstdint>

#include <Eigen/Geometry>

#include "tescalib/core/sim/scene_road.h"

namespace tescalib {
namespace sim {

/// Pose of the LiDAR (x forward, y left, z up; KITTI's velodyne frame) over time.
class VehicleTrajectory {
 public:
  /// `lane_offset`: lateral position of the lane centre (m, road frame); `lidar_height`: height
  /// of the LiDAR above the ground (m).
  VehicleTrajectory(const RoadPath& road, float lane_offset, uint64_t seed,
                    double lidar_height = 1.73);

  /// Station along the road at time t (s); 0 at t = 0.
  double station(double t) const;
  /// Speed at time t (m/s), within [8, 14].
  double speed(double t) const;
  /// Pose of the LiDAR in the world at time t.
  Eigen::Isometry3d worldFromLidar(double t) const;

 private:
  const RoadPath& road_;
  double lane_offset_, lidar_height_;
  double v_mean_, v_amp_, v_period_, v_phase_;
  double wobble_phase_[5];
};

}  // namespace sim
}  // namespace tescalib
