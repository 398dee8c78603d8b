#include "tescalib/core/lidar/scan_motion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <Eigen/Eigenvalues>

#include "tescalib/core/common/geometry.h"

namespace tescalib {

namespace {
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

constexpr double kMinRange = 3.0;  // m: the vehicle's own returns and the nearest ring
// m: beyond any automotive LiDAR's range; a stray far point (a bad return, a wrong unit) would
// make the voxel grid's index overflow, and PCL then returns the cloud unfiltered (5x slower).
constexpr double kMaxRange = 250.0;
constexpr float kVoxel = 0.3f;              // m
constexpr double kInlierDistance = 0.5;     // m, after registration
constexpr double kMaxRms = 0.25;            // m: a registration that fits worse is not trusted
constexpr double kMinInlierFraction = 0.3;  // of the registered scan's voxels
constexpr double kMaxSpeed = 70.0;          // m/s
constexpr double kMaxTurnRate = 1.5;        // rad/s

Cloud::Ptr voxelised(const LidarScan& scan) {
  Cloud::Ptr raw(new Cloud), out(new Cloud);
  raw->reserve(scan.size());
  for (const LidarPoint& p : scan)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
        std::hypot(p.x, p.y) > kMinRange && std::hypot(p.x, p.y, p.z) < kMaxRange)
      raw->push_back(pcl::PointXYZ(p.x, p.y, p.z));
  if (raw->empty()) return out;
  pcl::VoxelGrid<pcl::PointXYZ> vg;
  vg.setInputCloud(raw);
  vg.setLeafSize(kVoxel, kVoxel, kVoxel);
  vg.filter(*out);
  return out;
}

/// GICP of `source` to `target` from `init`: a wide stage (1.5 m correspondences, 30 iterations)
/// and a tight one (kInlierDistance, 60) on one registration object, so the points' covariances
/// are computed once.
Eigen::Matrix4f registerScans(const Cloud::Ptr& source, const Cloud::Ptr& target,
                              const Eigen::Matrix4f& init) {
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setInputSource(source);
  gicp.setInputTarget(target);
  Cloud aligned;
  gicp.setMaxCorrespondenceDistance(1.5);
  gicp.setMaximumIterations(30);
  gicp.align(aligned, init);
  const Eigen::Matrix4f wide = gicp.getFinalTransformation();
  gicp.setMaxCorrespondenceDistance(kInlierDistance);
  gicp.setMaximumIterations(60);
  gicp.align(aligned, wide);
  return gicp.getFinalTransformation();
}
/// ScanMotion::translation_constraint: the smallest over the largest eigenvalue of sum(n n^T),
/// n the normals of `target`'s local planes (10 neighbours, flat) under every third point of
/// `source` registered by T.
double translationConstraint(const Cloud& source, const pcl::KdTreeFLANN<pcl::PointXYZ>& tree,
                             const Cloud& target, const Eigen::Matrix4f& T) {
  constexpr int kNeighbours = 10;
  std::vector<int> idx(kNeighbours);
  std::vector<float> d2(kNeighbours);
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < source.size(); i += 3) {
    const Eigen::Vector4f q = T * Eigen::Vector4f(source[i].x, source[i].y, source[i].z, 1.f);
    if (tree.nearestKSearch(pcl::PointXYZ(q.x(), q.y(), q.z()), kNeighbours, idx, d2) <
            kNeighbours ||
        d2[0] > kInlierDistance * kInlierDistance)
      continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (int k : idx) {
      const Eigen::Vector3d v = target[k].getVector3fMap().cast<double>();
      mean += v;
      second += v * v.transpose();
    }
    mean /= kNeighbours;
    const Eigen::Matrix3d cov = second / kNeighbours - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    if (es.eigenvalues()(0) > 0.1 * es.eigenvalues()(1)) continue;  // not a plane
    const Eigen::Vector3d n = es.eigenvectors().col(0);
    info += n * n.transpose();
  }
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(info).eigenvalues();
  return ev(2) > 0 ? ev(0) / ev(2) : 0.0;
}

/// Nearest-neighbour queries in scan `a` (the registration's target).
struct NearTarget {
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  std::vector<int> idx = std::vector<int>(1);
  std::vector<float> d2 = std::vector<float>(1);
  explicit NearTarget(const Cloud::Ptr& a) { tree.setInputCloud(a); }
  /// Whether `a` has a point within kInlierDistance of (x, y, z); its squared distance in d2[0].
  bool near(float x, float y, float z) {
    return tree.nearestKSearch(pcl::PointXYZ(x, y, z), 1, idx, d2) == 1 &&
           d2[0] < kInlierDistance * kInlierDistance;
  }
};

/// Forward motion can be metres between the scans, beyond GICP's basin on a road whose structure
/// runs along it: GICP starts at the forward offset (0.25 m steps up to kMaxSpeed dt, and
/// backwards a fifth of that) that puts most of a sample of `b` near `a`. Coarse steps of 1 m,
/// then 0.25 m around the best: the count varies over about a metre (the inlier distance is
/// 0.5 m); half the time of 0.25 m steps throughout, same velocities.
double forwardOffset(const Cloud& b, NearTarget* a, double dt) {
  const double reach = kMaxSpeed * dt;
  auto overlap = [&](double x) {
    int count = 0;
    for (size_t i = 0; i < b.size(); i += 7) {
      const auto& p = b[i];
      if (a->near(p.x + float(x), p.y, p.z)) ++count;
    }
    return count;
  };
  double best_x = 0;
  int best_count = -1;
  auto consider = [&](double x) {
    const int count = overlap(x);
    if (count > best_count) best_count = count, best_x = x;
  };
  for (double x = -0.2 * reach; x <= reach + 1e-9; x += 1.0) consider(x);
  const double coarse_x = best_x;
  for (double dx : {-0.75, -0.5, -0.25, 0.25, 0.5, 0.75}) consider(coarse_x + dx);
  return best_x;
}

/// The motion's checks, in order: overlap, fit, constraint in every direction, plausibility.
void judgeMotion(size_t voxels, ScanMotion* m) {
  if (m->inliers < kMinInlierFraction * voxels)
    m->message = "the scans do not overlap after registration (" + std::to_string(m->inliers) +
                 " of " + std::to_string(voxels) + " voxels within 0.5 m)";
  else if (m->rms_m > kMaxRms)
    m->message = "the scan registration fits poorly (RMS " + std::to_string(m->rms_m) + " m)";
  else if (m->translation_constraint < kMinTranslationConstraint)
    m->message =
        "the scans do not constrain the motion in every direction (a road between guard rails "
        "or a tunnel: translation constraint " +
        std::to_string(m->translation_constraint) + ", at least " +
        std::to_string(kMinTranslationConstraint) + " needed)";
  else if (m->velocity.norm() > kMaxSpeed || m->angular_velocity.norm() > kMaxTurnRate)
    m->message =
        "implausible motion between the scans (" + std::to_string(m->velocity.norm()) + " m/s)";
  else
    m->valid = true;
}
}  // namespace

double sweepTime(double azimuth_rad, const ScanSweep& sweep) {
  // Azimuth swept since the reference instant, wrapped to [-pi, pi): the seam is behind.
  double a = (sweep.clockwise ? -1.0 : 1.0) * (azimuth_rad - sweep.reference_azimuth_rad);
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return (a - M_PI) / (2.0 * M_PI * sweep.rate_hz);
}

ScanMotion estimateScanMotion(const LidarScan& a, const LidarScan& b, double dt) {
  ScanMotion m;
  if (!(dt > 0)) {
    m.message = "the scans' stamps are not increasing (dt " + std::to_string(dt) + " s)";
    return m;
  }
  if (dt > kMaxScanMotionDt) {
    // The forward search below grows with dt (minutes for 1e4 s), and a constant velocity over
    // more than a few sweeps says nothing about the motion during one.
    m.message = "the scans are " + std::to_string(dt) + " s apart (at most " +
                std::to_string(kMaxScanMotionDt) + " s: a constant velocity over them is no model)";
    return m;
  }
  const Cloud::Ptr ca = voxelised(a), cb = voxelised(b);
  if (ca->size() < 200 || cb->size() < 200) {
    m.message = "too few LiDAR points beyond " + std::to_string(int(kMinRange)) + " m to register";
    return m;
  }
  NearTarget near_a(ca);
  Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
  T(0, 3) = float(forwardOffset(*cb, &near_a, dt));
  T = registerScans(cb, ca, T);

  // Inliers and their RMS, measured independently of GICP's own score.
  double sum = 0;
  for (const auto& p : cb->points) {
    const Eigen::Vector4f q = T * Eigen::Vector4f(p.x, p.y, p.z, 1.f);
    if (near_a.near(q.x(), q.y(), q.z())) {
      sum += near_a.d2[0];
      ++m.inliers;
    }
  }
  m.translation_constraint = translationConstraint(*cb, near_a.tree, *ca, T);
  m.rms_m = m.inliers > 0 ? std::sqrt(sum / m.inliers) : std::numeric_limits<double>::infinity();
  const Eigen::Matrix4d Td = T.cast<double>();
  m.velocity = Td.topRightCorner<3, 1>() / dt;
  m.angular_velocity = logSO3(Td.topLeftCorner<3, 3>()) / dt;
  judgeMotion(cb->size(), &m);
  return m;
}

bool hasPointTimes(const LidarScan& scan) {
  return std::any_of(scan.begin(), scan.end(),
                     [](const LidarPoint& p) { return std::isfinite(p.time); });
}

void deskewScan(LidarScan* scan, const ScanMotion& motion, const ScanSweep& sweep,
                double time_offset) {
  if (!motion.valid) return;
  for (LidarPoint& p : *scan) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    // The sensor at time t is at exp(w t), v t in the reference frame: a point it measured then
    // is exp(w t) p + v t there. A point's own time is relative to the cloud's stamp; the
    // azimuth model's, to the reference instant (the image stamp) itself.
    const double t =
        std::isfinite(p.time) ? p.time + time_offset : sweepTime(std::atan2(p.y, p.x), sweep);
    const Eigen::Vector3d q =
        expSO3(motion.angular_velocity * t) * Eigen::Vector3d(p.x, p.y, p.z) + motion.velocity * t;
    p.x = float(q.x()), p.y = float(q.y()), p.z = float(q.z());
  }
}

}  // namespace tescalib
