// Motion compensation of swept LiDAR scans: the sweep's timing, de-skewing a scan swept in a
// known motion, and the scan-to-scan velocity on a generated drive and on real KITTI frames.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/sim/simulator.h"
#include "test_util.h"

using namespace tescalib;

TEST(ScanMotion, SweepTimeFollowsTheRotation) {
  ScanSweep s;  // 10 Hz, clockwise, reference forward
  EXPECT_NEAR(sweepTime(0.0, s), 0.0, 1e-12);
  EXPECT_NEAR(sweepTime(M_PI / 2, s), -0.025, 1e-12);   // left: swept before the reference
  EXPECT_NEAR(sweepTime(-M_PI / 2, s), 0.025, 1e-12);   // right: after it
  EXPECT_NEAR(sweepTime(M_PI - 1e-9, s), -0.05, 1e-9);  // the seam is behind
  EXPECT_NEAR(sweepTime(-M_PI + 1e-9, s), 0.05, 1e-9);
  s.clockwise = false;
  EXPECT_NEAR(sweepTime(M_PI / 2, s), 0.025, 1e-12);
  s.clockwise = true;
  s.reference_azimuth_rad = M_PI / 2;
  s.rate_hz = 20;
  EXPECT_NEAR(sweepTime(M_PI / 2, s), 0.0, 1e-12);
  EXPECT_NEAR(sweepTime(0.0, s), 0.0125, 1e-12);
}

namespace {
struct Plane {
  Eigen::Vector3d n;
  double d;  // n.x = d
};
const std::vector<Plane> kRoom = {{Eigen::Vector3d::UnitX(), 30.0},
                                  {Eigen::Vector3d::UnitX(), -25.0},
                                  {Eigen::Vector3d::UnitY(), 9.0},
                                  {Eigen::Vector3d::UnitY(), -11.0},
                                  {Eigen::Vector3d::UnitZ(), -1.7}};

double distanceToRoom(const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Plane& pl : kRoom) best = std::min(best, std::fabs(pl.n.dot(p) - pl.d));
  return best;
}
}  // namespace

TEST(ScanMotion, DeskewPutsASweptScanBackOnItsWalls) {
  // A sensor sweeping a box room while moving at 12 m/s and turning at 6 deg/s: each ray is cast
  // from the pose the sensor had when it fired, and reported in the sensor frame of that moment.
  ScanMotion m;
  m.velocity = Eigen::Vector3d(12.0, 0.4, 0.0);
  m.angular_velocity = Eigen::Vector3d(0.0, 0.0, 0.1);
  m.valid = true;
  const ScanSweep sweep;
  LidarScan scan;
  for (int a = -180; a < 180; ++a) {
    for (int e = -24; e <= 2; e += 2) {
      const double az = (a + 0.5) * M_PI / 180.0, el = e * M_PI / 180.0;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      const double t = sweepTime(az, sweep);
      const Eigen::Matrix3d R = expSO3(m.angular_velocity * t);
      const Eigen::Vector3d c = m.velocity * t, dw = R * d;
      double s_hit = std::numeric_limits<double>::infinity();
      for (const Plane& pl : kRoom) {
        const double den = pl.n.dot(dw);
        if (std::fabs(den) < 1e-9) continue;
        const double s = (pl.d - pl.n.dot(c)) / den;
        if (s > 0) s_hit = std::min(s_hit, s);
      }
      LidarPoint p;
      p.x = float(s_hit * d.x()), p.y = float(s_hit * d.y()), p.z = float(s_hit * d.z());
      scan.push_back(p);
    }
  }
  double before = 0;
  for (const LidarPoint& p : scan) before = std::max(before, distanceToRoom({p.x, p.y, p.z}));
  LidarScan fixed = scan;
  deskewScan(&fixed, m, sweep);
  double after = 0;
  for (const LidarPoint& p : fixed) after = std::max(after, distanceToRoom({p.x, p.y, p.z}));
  EXPECT_GT(before, 0.5);  // 12 m/s x 0.05 s at the seam
  EXPECT_LT(after, 2e-4);  // float precision
  // Per-point times from the driver (here stamped 20 ms before the reference instant) take the
  // place of the sweep model, even a wrong one.
  LidarScan timed = scan;
  for (LidarPoint& p : timed) p.time = float(sweepTime(std::atan2(p.y, p.x), sweep) + 0.02);
  ScanSweep wrong;
  wrong.clockwise = false;
  deskewScan(&timed, m, wrong, -0.02);
  double after_timed = 0;
  for (const LidarPoint& p : timed)
    after_timed = std::max(after_timed, distanceToRoom({p.x, p.y, p.z}));
  EXPECT_LT(after_timed, 2e-4);
  // An invalid motion leaves the scan as it is.
  LidarScan same = scan;
  m.valid = false;
  deskewScan(&same, m, sweep);
  EXPECT_EQ(same[100].x, scan[100].x);
}

TEST(ScanMotion, RegistrationRecoversTheGeneratedDrivesVelocity) {
  SimOptions o;
  o.frames = 6;
  o.seed = 1;
  const Simulator sim(o);
  const LidarScan a = sim.renderScan(0), b = sim.renderScan(5);
  const Eigen::Isometry3d T = sim.worldFromLidar(0).inverse() * sim.worldFromLidar(5);
  const double dt = sim.stamp(5) - sim.stamp(0);
  const ScanMotion m = estimateScanMotion(a, b, dt);
  ASSERT_TRUE(m.valid) << m.message;
  const Eigen::Vector3d v = T.translation() / dt, w = logSO3(T.linear()) / dt;
  std::printf(
      "generated: velocity %.3f %.3f %.3f m/s (truth %.3f %.3f %.3f), turn %.3f deg/s "
      "(truth %.3f), RMS %.3f m\n",
      m.velocity.x(), m.velocity.y(), m.velocity.z(), v.x(), v.y(), v.z(),
      m.angular_velocity.z() * kDegPerRad, w.z() * kDegPerRad, m.rms_m);
  EXPECT_GT(v.norm(), 5.0);  // the generated vehicle drives at 8-14 m/s
  EXPECT_LT((m.velocity - v).norm(), 0.05);
  EXPECT_LT((m.angular_velocity - w).norm() * kDegPerRad, 0.1);
}

TEST(ScanMotion, ARoadBetweenGuardRailsIsNotAValidMotion) {
  // The generated highway (road, guard rails): scan-to-scan registration slides along the road
  // (0.3-1.3 m per 0.1 s, a velocity 3-13 m/s wrong), which must not be declared valid.
  SimOptions o;
  o.frames = 12;
  o.seed = 2;
  o.scenario = Scenario::kHighway;
  o.lidar_sweep = true;
  const Simulator highway(o);
  const ScanMotion m = estimateScanMotion(highway.renderScan(9), highway.renderScan(10), 0.1);
  std::printf("highway: translation constraint %.4f, velocity %.2f m/s: %s\n",
              m.translation_constraint, m.velocity.x(), m.message.c_str());
  EXPECT_FALSE(m.valid);
  EXPECT_LT(m.translation_constraint, kMinTranslationConstraint);
  EXPECT_NE(m.message.find("do not constrain"), std::string::npos) << m.message;
  o.scenario = Scenario::kUrban;
  const Simulator urban(o);
  const ScanMotion u = estimateScanMotion(urban.renderScan(9), urban.renderScan(10), 0.1);
  EXPECT_TRUE(u.valid) << u.message;
  EXPECT_GT(u.translation_constraint, 2 * kMinTranslationConstraint);
}

TEST(ScanMotion, AStrayFarPointDoesNotTurnTheVoxelFilterOff) {
  // One return 7 km away makes PCL's voxel grid index overflow, and PCL then returns the cloud
  // unfiltered: six times the inliers, five times the time, another velocity.
  SimOptions o;
  o.frames = 12;
  o.seed = 2;
  o.lidar_sweep = true;
  const Simulator urban(o);
  const LidarScan a = urban.renderScan(9), b = urban.renderScan(10);
  LidarScan a_far = a, b_far = b;
  LidarPoint far;
  far.x = far.y = 5000.f;
  a_far.push_back(far);
  b_far.push_back(far);
  const ScanMotion m = estimateScanMotion(a, b, 0.1);
  const ScanMotion f = estimateScanMotion(a_far, b_far, 0.1);
  ASSERT_TRUE(m.valid) << m.message;
  EXPECT_TRUE(f.valid) << f.message;
  EXPECT_EQ(f.inliers, m.inliers);
  EXPECT_LT((f.velocity - m.velocity).norm(), 1e-6);
}

TEST(ScanMotion, BadInputIsRefusedWithAMessage) {
  const LidarScan empty;
  LidarScan few(50);
  for (size_t i = 0; i < few.size(); ++i) few[i].x = 5.f + i;
  ScanMotion m = estimateScanMotion(few, few, 0.1);
  EXPECT_FALSE(m.valid);
  EXPECT_NE(m.message.find("too few"), std::string::npos) << m.message;
  m = estimateScanMotion(empty, few, -0.1);
  EXPECT_FALSE(m.valid);
  EXPECT_NE(m.message.find("not increasing"), std::string::npos) << m.message;
  m = estimateScanMotion(few, few, 1e4);  // took minutes before it was refused
  EXPECT_FALSE(m.valid);
  EXPECT_NE(m.message.find("s apart"), std::string::npos) << m.message;
}

TEST(ScanMotion, KittiHighwayScansAreSweptAtTwelveMetresPerSecond) {
  SKIP_WITHOUT_KITTI();
  // Sequence 04 (2011_09_30) drives straight on at about 12.6 m/s: over its keyframe pair
  // (frames 0 and 5, 0.52 s apart) the registration must find that forward motion.
  const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/04");
  ASSERT_GE(seq.size(), 2u);
  const ScanMotion m =
      estimateScanMotion(seq.loadScan(0), seq.loadScan(1), seq.stamp(1) - seq.stamp(0));
  ASSERT_TRUE(m.valid) << m.message;
  std::printf("KITTI 04: velocity %.2f %.2f %.2f m/s, %.2f deg/s, RMS %.3f m\n", m.velocity.x(),
              m.velocity.y(), m.velocity.z(), m.angular_velocity.norm() * kDegPerRad, m.rms_m);
  EXPECT_NEAR(m.velocity.x(), 12.6, 0.5);
  EXPECT_LT(std::hypot(m.velocity.y(), m.velocity.z()), 0.5);
  EXPECT_LT(m.angular_velocity.norm() * kDegPerRad, 2.0);
}
