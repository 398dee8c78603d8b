#include "tescalib/core/sim/random_rig.h"

#include <algorithm>
#include <cmath>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {
namespace {

constexpr double kRad = M_PI / 180.0;

/// A value of magnitude in [lo, hi) and random sign.
double signedMagnitude(SimRandom* r, double lo, double hi) {
  const double m = r->uniform(lo, hi);
  return r->chance(0.5) ? m : -m;
}

/// Roll, pitch, yaw (rad) about x, y, z of a frame: Rz * Ry * Rx.
Eigen::Matrix3d rpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// The shared K and the image size from a focal length and fields of view.
void drawIntrinsics(SimRandom* r, SimRig* rig, Eigen::Matrix3d* K) {
  rig->width = r->uniformInt(640, 1400);
  const double hfov = r->uniform(60.0, 90.0) * kRad, vfov = r->uniform(25.0, 50.0) * kRad;
  const double f = std::clamp(rig->width / (2 * std::tan(hfov / 2)), 400.0, 1100.0);
  rig->height = std::clamp(static_cast<int>(std::lround(2 * f * std::tan(vfov / 2))), 240, 600);
  const double cx = rig->width * (0.5 + r->uniform(-0.03, 0.03));
  const double cy = rig->height * (0.5 + r->uniform(-0.05, 0.05));
  *K << f, 0, cx, 0, f, cy, 0, 0, 1;
}

/// P0 = K [I | 0]; P2 and P3 = K [I | t]: the left camera a few cm from cam0, the right one a
/// baseline further and a few mm off the left camera's x axis.
void drawPair(SimRandom* r, const Eigen::Matrix3d& K, SimRig* rig) {
  const Eigen::Vector3d t2(r->uniform(0.0, 0.1), signedMagnitude(r, 0.0, 0.002),
                           signedMagnitude(r, 0.0, 0.006));
  const double baseline = r->uniform(0.12, 0.6);
  const Eigen::Vector3d off(-baseline, signedMagnitude(r, 0.0005, 0.004),
                            signedMagnitude(r, 0.0005, 0.004));
  KittiOdometryCalib& c = rig->calib;
  for (int i = 0; i < 4; ++i) {
    c.P[i].leftCols<3>() = K;
    c.P[i].col(3).setZero();
  }
  c.P[1].col(3) = K * Eigen::Vector3d(-baseline, 0, 0);
  c.P[2].col(3) = K * t2;
  c.P[3].col(3) = K * (t2 + off);
}

/// The cam0 frame in the vehicle frame: looking forward, 1.3-1.8 m above the ground.
Eigen::Isometry3d drawCameraMount(SimRandom* r) {
  Eigen::Matrix3d forward;  // camera x right, y down, z forward
  forward << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double roll = r->uniform(-1.0, 1.0), pitch_down = r->uniform(-1.0, 3.0);
  T.linear() = rpy(roll * kRad, pitch_down * kRad, r->uniform(-2.0, 2.0) * kRad) * forward;
  T.translation() = Eigen::Vector3d(r->uniform(0.0, 0.6), r->uniform(-0.3, 0.3),
                                    r->uniform(1.3, 1.8) - kVehicleFrameHeight);
  return T;
}

/// The LiDAR in the vehicle frame: within 1 m of the camera, not in front of it by more than
/// 0.3 m, at least 1.2 m above the ground; a driver's axis convention turned a little.
Eigen::Isometry3d drawLidarMount(SimRandom* r, const Eigen::Vector3d& camera) {
  Eigen::Vector3d offset;
  do {
    offset = Eigen::Vector3d(r->uniform(-0.9, 0.3), r->uniform(-0.6, 0.6), r->uniform(-0.1, 0.6));
  } while (offset.norm() > 1.0 || offset.norm() < 0.1 ||
           camera.z() + offset.z() + kVehicleFrameHeight < 1.2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double convention = 90.0 * r->uniformInt(0, 3);
  T.linear() = rpy(r->uniform(-3.0, 3.0) * kRad, r->uniform(-3.0, 3.0) * kRad,
                   (convention + r->uniform(-3.0, 3.0)) * kRad);
  T.translation() = camera + offset;
  return T;
}

}  // namespace

SimRig randomSimRig(uint64_t seed) {
  SimRandom r(subSeed(seed, 0x5249475fULL));
  SimRig rig;
  Eigen::Matrix3d K;
  drawIntrinsics(&r, &rig, &K);
  drawPair(&r, K, &rig);
  const Eigen::Isometry3d T_vehicle_cam0 = drawCameraMount(&r);
  rig.T_vehicle_lidar = drawLidarMount(&r, T_vehicle_cam0.translation());
  const Eigen::Isometry3d T_cam0_lidar = T_vehicle_cam0.inverse() * rig.T_vehicle_lidar;
  rig.calib.Tr = T_cam0_lidar.matrix().topRows<3>();
  return rig;
}

}  // namespace sim
}  // namespace tescalib
