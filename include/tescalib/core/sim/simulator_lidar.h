// Simulates one revolution of an HDL-64E-like spinning LiDAR in a generated world, with the
// paper's measurement noise model (section "Measurement Noise Model", eq. lidar_point_gt):
// the true beam direction is the nominal one turned by w_l ~ N(0, sigma_l^2 I2) in its tangent
// plane, and the measured distance is the true one plus w_d ~ N(0, sigma_d^2). The sensor reports
// the measured distance along the NOMINAL direction, p = d * omega, exactly as the model states.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/sim/scene_builder.h"

namespace tescalib {
namespace sim {

/// Beam layout of the spinning sensor.
struct LidarModel {
  std::vector<double> elevation_deg;  ///< beam elevations, ring 0 (lowest) first
  int points_per_ring = 2000;         ///< azimuth steps per revolution
  double max_range = 120.0;           ///< m; no return beyond (and none from the sky)
  double min_range = 1.0;             ///< m

  /// 64 beams like the HDL-64E: upper block +2.0 .. -8.33 deg (1/3 deg steps), lower block
  /// -8.83 .. -24.9 deg (about 1/2 deg steps).
  static LidarModel hdl64e();
};

/// Measurement noise of the LiDAR, and the systematic errors of a real sensor's lasers.
struct LidarNoise {
  double range_sigma = 0.02;         ///< sigma_d: along the beam (m)
  double direction_sigma_rad = 0.0;  ///< sigma_l: beam direction, per tangent axis (rad)
  double intensity_sigma = 0.01;     ///< reflectance noise (0..1 scale)
  /// Per laser (ring 0 lowest; empty: none): added to every range of the laser (m).
  std::vector<double> laser_range_offset_m;
  /// Per laser: the true elevation minus the nominal one the points are reported along (rad).
  std::vector<double> laser_elevation_rad;
  double range_scale = 1;  ///< reported range = range_scale * true range + offset + noise
  /// Share of the beams whose footprint straddles a depth edge (the ranges under its two halves
  /// differ by more than 0.3 m) that return a range between the two.
  double mixed_pixel_fraction = 0;
};

/// One scan in KITTI's storage order: ring after ring, top beam first, each ring one
/// counter-clockwise revolution starting just after azimuth 0 (forward). `ring` is set (0 =
/// lowest). Points carry the material's reflectivity, weakened at grazing incidence, in 0..1.
LidarScan simulateLidarScan(const SceneWorld& world, const Eigen::Isometry3d& T_world_lidar,
                            const LidarModel& model, const LidarNoise& noise, uint64_t seed,
                            int threads = 1);

/// The same swept over one revolution as a real spinning sensor is: the beam at azimuth az fires
/// at time `sweepTime(az, sweep)` (scan_motion.h; clockwise at 10 Hz, forward at 0 by default)
/// from the pose `world_from_lidar(t)` and is reported in the sensor frame of that moment, so
/// a moving sensor's scan is skewed as a raw driver delivers it.
LidarScan simulateSweptLidarScan(const SceneWorld& world,
                                 const std::function<Eigen::Isometry3d(double)>& world_from_lidar,
                                 const LidarModel& model, const LidarNoise& noise, uint64_t seed,
                                 int threads = 1);

}  // namespace sim
}  // namespace tescalib
