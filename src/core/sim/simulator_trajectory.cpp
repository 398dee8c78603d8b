#include "tescalib/core/sim/simulator_trajectory.h"

#include <cmath>

#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {

namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

VehicleTrajectory::VehicleTrajectory(const RoadPath& road, float lane_offset, uint64_t seed,
                                     double lidar_height)
    : road_(road), lane_offset_(lane_offset), lidar_height_(lidar_height) {
  SimRandom rng(subSeed(seed, 0x7a1));
  // v_mean +- v_amp stays within [8, 14] m/s.
  v_mean_ = rng.uniform(10.5, 11.5);
  v_amp_ = rng.uniform(1.5, 2.5);
  v_period_ = rng.uniform(20.0, 40.0);
  v_phase_ = rng.uniform(0.0, 2 * M_PI);
  for (double& p : wobble_phase_) p = rng.uniform(0.0, 2 * M_PI);
}

double VehicleTrajectory::speed(double t) const {
  return v_mean_ + v_amp_ * std::sin(2 * M_PI * t / v_period_ + v_phase_);
}

double VehicleTrajectory::station(double t) const {
  const double w = 2 * M_PI / v_period_;
  return v_mean_ * t - v_amp_ / w * (std::cos(w * t + v_phase_) - std::cos(v_phase_));
}

Eigen::Isometry3d VehicleTrajectory::worldFromLidar(double t) const {
  const double s = station(t);
  auto wobble = [&](int k, double amplitude, double period) {
    return amplitude * std::sin(2 * M_PI * t / period + wobble_phase_[k]);
  };
  const double l = lane_offset_ + wobble(0, 0.15, 17.0);
  const Eigen::Vector2d xy = road_.toWorld(s, l);
  const double yaw = road_.heading(s) + wobble(1, 0.2 * kDeg, 7.0);
  const double pitch = wobble(2, 0.15 * kDeg, 3.1);
  const double roll = wobble(3, 0.1 * kDeg, 4.3);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(xy.x(), xy.y(), lidar_height_ + wobble(4, 0.01, 2.3));
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return T;
}

}  // namespace sim
}  // namespace tescalib
