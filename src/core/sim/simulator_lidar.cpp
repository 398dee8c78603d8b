#include "tescalib/core/sim/simulator_lidar.h"

#include <algorithm>
#include <cmath>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/sim/scene_culling.h"
#include "tescalib/core/sim/scene_surface.h"
#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {

namespace {
constexpr int kAzimuthBins = 720;
constexpr float kBeamDivergence = 0.002f;  // rad; the LiDAR's texture footprint
constexpr float kMixedEdge = 0.3f;         // m; a depth edge under a beam's footprint

/// values[ring], or 0 when `values` is empty.
double laserValue(const std::vector<double>& values, int ring) {
  return values.empty() ? 0.0 : values[static_cast<size_t>(ring)];
}
}  // namespace

LidarModel LidarModel::hdl64e() {
  LidarModel m;
  m.elevation_deg.resize(64);
  for (int i = 0; i < 32; ++i) {
    m.elevation_deg[i] = -24.9 + (24.9 - 8.83) * i / 31.0;      // lower block
    m.elevation_deg[32 + i] = -8.33 + (8.33 + 2.0) * i / 31.0;  // upper block
  }
  return m;
}

namespace {
constexpr int kSweepChunks = 90;  // culling poses per revolution (4 deg, 1.1 ms each)

/// Azimuth of azimuth step k of n (rad, counter-clockwise from the front; k may be fractional).
double beamAzimuth(double k, int n) { return 2 * M_PI * (k + 0.5) / n; }

/// The reflectance a beam along `d` from `origin` reports at `hit`: the material's, weakened at
/// grazing incidence, plus `noise`, clamped to 0..1 in steps of 0.01.
float beamIntensity(const SceneWorld& world, const TraceResult& hit, const Eigen::Vector3f& origin,
                    const Eigen::Vector3f& d, float noise) {
  SurfacePoint sp = surfaceAt(world, hit, origin, d);
  const Eigen::Vector3f t1 = sp.normal.unitOrthogonal();
  sp.dpdx = hit.t * kBeamDivergence * t1;
  sp.dpdy = hit.t * kBeamDivergence * sp.normal.cross(t1);
  const SurfaceLook look = lookAt(world, hit, sp);
  const float incidence = std::fabs(sp.normal.dot(d));
  const float intensity = look.reflectivity * (0.35f + 0.65f * incidence) + noise;
  return std::round(std::clamp(intensity, 0.f, 1.f) * 100.f) / 100.f;
}

/// One revolution; beam k (azimuth step) is fired from `pose(k)` and traced among the candidates
/// culled from `cull_pose(chunk(k))`.
template <class PoseOf, class ChunkOf>
LidarScan spin(const SceneWorld& world, const std::vector<Eigen::Isometry3d>& cull_poses,
               const PoseOf& pose, const ChunkOf& chunk, const LidarModel& model,
               const LidarNoise& noise, uint64_t seed, int threads) {
  std::vector<TileCandidates> sectors;
  for (const Eigen::Isometry3d& T : cull_poses)
    sectors.push_back(cullSpinning(world.prims, T.linear().cast<float>().transpose(),
                                   T.translation().cast<float>(),
                                   static_cast<float>(model.max_range) + 1.f, kAzimuthBins));
  const int rings = static_cast<int>(model.elevation_deg.size());
  const int n = model.points_per_ring;
  const uint32_t seed32 = static_cast<uint32_t>(seed ^ (seed >> 32));
  std::vector<LidarScan> per_ring(rings);
  parallelFor(rings, resolveThreads(threads), [&](int order) {
    const int ring = rings - 1 - order;  // stored top beam first
    const double el = model.elevation_deg[ring] * M_PI / 180.0;
    const double el_true = el + laserValue(noise.laser_elevation_rad, ring);
    const double range_offset = laserValue(noise.laser_range_offset_m, ring);
    LidarScan& out = per_ring[order];
    out.reserve(n);
    for (int k = 0; k < n; ++k) {
      const double az = beamAzimuth(k, n);
      const Eigen::Vector3d omega(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                  std::sin(el));
      const Eigen::Vector3d omega_true =
          el_true == el ? omega
                        : Eigen::Vector3d(std::cos(el_true) * std::cos(az),
                                          std::cos(el_true) * std::sin(az), std::sin(el_true));
      // Tangent basis N(omega) = [N1 N2]: azimuth and elevation directions.
      const Eigen::Vector3d n1(-std::sin(az), std::cos(az), 0.0);
      const Eigen::Vector3d n2 = omega_true.cross(n1);
      const uint32_t id = static_cast<uint32_t>(ring * n + k);
      const double w1 = noise.direction_sigma_rad * gaussianFromHash(hash32(seed32, id, 0u));
      const double w2 = noise.direction_sigma_rad * gaussianFromHash(hash32(seed32, id, 1u));
      const Eigen::Vector3f beam = (omega_true + w1 * n1 + w2 * n2).normalized().cast<float>();
      const Eigen::Isometry3d& T = pose(k);
      const Eigen::Vector3f origin = T.translation().cast<float>();
      const Eigen::Vector3f d = T.linear().cast<float>() * beam;
      const int c = chunk(k);
      const int bin = azimuthBin(beam, kAzimuthBins);  // the sensor turns little within a chunk
      const TraceResult hit =
          traceRay(world.prims, sectors[c].begin(bin, 0), sectors[c].end(bin, 0), origin, d,
                   static_cast<float>(model.max_range) + 1.f);
      if (hit.prim == TraceResult::kNoHit) continue;
      double t = hit.t;
      if (noise.mixed_pixel_fraction > 0 &&
          unitFloat(hash32(seed32, id, 4u)) < noise.mixed_pixel_fraction) {
        // The footprint's other half, a beam divergence further along the azimuth.
        const Eigen::Vector3f d2 =
            T.linear().cast<float>() * (beam + kBeamDivergence * n1.cast<float>()).normalized();
        const TraceResult h2 =
            traceRay(world.prims, sectors[c].begin(bin, 0), sectors[c].end(bin, 0), origin, d2,
                     static_cast<float>(model.max_range) + 1.f);
        if (h2.prim != TraceResult::kNoHit && std::fabs(h2.t - hit.t) > kMixedEdge)
          t = hit.t + unitFloat(hash32(seed32, id, 5u)) * (h2.t - hit.t);
      }
      const double range = noise.range_scale * t + range_offset +
                           noise.range_sigma * gaussianFromHash(hash32(seed32, id, 2u));
      if (range > model.max_range || range < model.min_range) continue;
      LidarPoint p;
      p.x = static_cast<float>(range * omega.x());
      p.y = static_cast<float>(range * omega.y());
      p.z = static_cast<float>(range * omega.z());
      p.intensity = beamIntensity(
          world, hit, origin, d,
          static_cast<float>(noise.intensity_sigma) * gaussianFromHash(hash32(seed32, id, 3u)));
      p.ring = static_cast<uint16_t>(ring);
      out.push_back(p);
    }
  });
  LidarScan scan;
  size_t total = 0;
  for (const auto& r : per_ring) total += r.size();
  scan.reserve(total);
  for (const auto& r : per_ring) scan.insert(scan.end(), r.begin(), r.end());
  return scan;
}
}  // namespace

LidarScan simulateLidarScan(const SceneWorld& world, const Eigen::Isometry3d& T_world_lidar,
                            const LidarModel& model, const LidarNoise& noise, uint64_t seed,
                            int threads) {
  return spin(
      world, {T_world_lidar}, [&](int) -> const Eigen::Isometry3d& { return T_world_lidar; },
      [](int) { return 0; }, model, noise, seed, threads);
}

LidarScan simulateSweptLidarScan(const SceneWorld& world,
                                 const std::function<Eigen::Isometry3d(double)>& world_from_lidar,
                                 const LidarModel& model, const LidarNoise& noise, uint64_t seed,
                                 int threads) {
  const ScanSweep sweep;
  const int n = model.points_per_ring;
  std::vector<Eigen::Isometry3d> poses(n), cull(kSweepChunks);
  for (int k = 0; k < n; ++k) poses[k] = world_from_lidar(sweepTime(beamAzimuth(k, n), sweep));
  // Candidates are culled per chunk of azimuth from the chunk's middle pose: within a chunk the
  // sensor moves by at most a few cm, inside culling's one-sector margin beyond a few metres.
  const int per_chunk = (n + kSweepChunks - 1) / kSweepChunks;
  for (int c = 0; c < kSweepChunks; ++c)
    cull[c] =
        world_from_lidar(sweepTime(beamAzimuth(c * per_chunk + 0.5 * per_chunk - 0.5, n), sweep));
  return spin(
      world, cull, [&](int k) -> const Eigen::Isometry3d& { return poses[k]; },
      [per_chunk](int k) { return k / per_chunk; }, model, noise, seed, threads);
}

}  // namespace sim
}  // namespace tescalib
