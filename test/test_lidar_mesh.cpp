// The LiDAR triangle mesh (the LiDAR-stereo solver's preprocessing): faces from adjacent rings and
// azimuths, none across a depth discontinuity or at a grazing angle, normals towards the sensor and
// fitted to the neighbourhood's plane.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/lidar/lidar_mesh.h"

namespace {

using tescalib::kDegPerRad;
using tescalib::LidarMesh;
using tescalib::LidarMeshSettings;
using tescalib::LidarScan;

constexpr double kHeight = 1.73;  // sensor above the road, m (KITTI)

// One revolution of a 64-ring sensor (elevations -24.9..+2 deg, as the HDL-64E) in a scene of a
// flat road, a wall 10 m ahead left of the axis (y in [-3, 0)) and one 16 m ahead right of it
// (y in [0, 3]): a 6 m depth step between neighbouring azimuths. Range noise N(0, sigma).
LidarScan stepScene(double range_sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  LidarScan scan;
  const int rings = 64, per_ring = 1000;
  for (int r = 0; r < rings; ++r) {
    const double elev = (-24.9 + 26.9 * r / (rings - 1)) / kDegPerRad;
    for (int k = 0; k < per_ring; ++k) {
      const double az = 2 * M_PI * (k + 0.5) / per_ring - M_PI;
      const Eigen::Vector3d d(std::cos(elev) * std::cos(az), std::cos(elev) * std::sin(az),
                              std::sin(elev));
      double t = std::numeric_limits<double>::infinity();
      auto wall = [&](double x, double y0, double y1) {
        if (d.x() <= 0) return;
        const double tw = x / d.x();
        const Eigen::Vector3d p = tw * d;
        if (p.y() >= y0 && p.y() < y1 && p.z() >= -kHeight && p.z() <= 3.0) t = std::min(t, tw);
      };
      wall(10.0, -3.0, 0.0);
      wall(16.0, 0.0, 3.0);
      if (d.z() < 0) t = std::min(t, -kHeight / d.z());
      if (!(t < 80.0)) continue;
      const Eigen::Vector3d p = (t + range_sigma * noise(rng)) * d;
      tescalib::LidarPoint lp;
      lp.x = float(p.x()), lp.y = float(p.y()), lp.z = float(p.z());
      lp.ring = uint16_t(r);
      scan.push_back(lp);
    }
  }
  return scan;
}

enum Surface { kNearWall, kFarWall, kRoad, kOther };
// A face belongs to a surface when all three vertices lie on it (within `tol`, m); faces at the
// walls' feet, with vertices on the wall and on the road, are neither.
Surface surfaceOf(const tescalib::MeshFace& f, float tol = 0.01f) {
  auto all = [&](auto on) { return on(f.a) && on(f.b) && on(f.c); };
  auto above_road = [&](const Eigen::Vector3f& v) { return v.z() > -kHeight + 5 * tol; };
  if (all([&](const Eigen::Vector3f& v) { return std::fabs(v.x() - 10.f) < tol && above_road(v); }))
    return kNearWall;
  if (all([&](const Eigen::Vector3f& v) { return std::fabs(v.x() - 16.f) < tol && above_road(v); }))
    return kFarWall;
  if (all([&](const Eigen::Vector3f& v) { return std::fabs(v.z() + kHeight) < tol; })) return kRoad;
  return kOther;
}

double angleDeg(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::acos(std::min(1.0, std::fabs(double(a.normalized().dot(b.normalized()))))) *
         kDegPerRad;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST(LidarMesh, NoFaceAcrossADepthStepOrAtAGrazingAngle) {
  const LidarMesh mesh = tescalib::buildLidarMesh(stepScene(0.0, 1), LidarMeshSettings{});
  int near = 0, far = 0, road = 0, across = 0, road_beyond_grazing = 0;
  double worst_incidence = 0;
  for (const auto& f : mesh.faces) {
    // Normals are unit and face the sensor.
    EXPECT_NEAR(f.normal.norm(), 1.f, 1e-4f);
    EXPECT_LT(f.normal.dot(f.centroid), 0.f);
    // A face with vertices on both walls bridges the 6 m step.
    const float xmin = std::min({f.a.x(), f.b.x(), f.c.x()});
    const float xmax = std::max({f.a.x(), f.b.x(), f.c.x()});
    const float zmin = std::min({f.a.z(), f.b.z(), f.c.z()});
    if (xmin < 11.f && xmax > 15.f && zmin > -kHeight + 0.1f) ++across;
    const Surface s = surfaceOf(f);
    near += s == kNearWall, far += s == kFarWall;
    if (s == kRoad) {
      ++road;
      // The road's true incidence at the centroid: 80 deg (the default limit) is reached
      // where the beam is 10 deg below the horizon, 1.73 / sin(10 deg) = 9.96 m away.
      const double incidence = std::acos(kHeight / f.centroid.norm()) * kDegPerRad;
      worst_incidence = std::max(worst_incidence, incidence);
      if (f.centroid.norm() > 10.5f) ++road_beyond_grazing;
    }
  }
  EXPECT_EQ(across, 0);
  // Both sides of the step are meshed, and the road up to where it becomes grazing.
  EXPECT_GT(near, 1000);
  EXPECT_GT(far, 300);
  EXPECT_GT(road, 5000);
  EXPECT_EQ(road_beyond_grazing, 0);
  EXPECT_LT(worst_incidence, 80.5);

  // Without the rules the step and the far road are meshed: the test can tell.
  LidarMeshSettings loose;
  loose.max_edge_ratio = 10.0, loose.max_edge_abs = 100.0, loose.max_incidence_deg = 89.9;
  const LidarMesh all = tescalib::buildLidarMesh(stepScene(0.0, 1), loose);
  int across_loose = 0, far_road_loose = 0;
  for (const auto& f : all.faces) {
    const float xmin = std::min({f.a.x(), f.b.x(), f.c.x()});
    const float xmax = std::max({f.a.x(), f.b.x(), f.c.x()});
    const float zmin = std::min({f.a.z(), f.b.z(), f.c.z()});
    if (xmin < 11.f && xmax > 15.f && zmin > -kHeight + 0.1f) ++across_loose;
    if (surfaceOf(f) == kRoad && f.centroid.norm() > 10.5f) ++far_road_loose;
  }
  EXPECT_GT(across_loose, 10);
  EXPECT_GT(far_road_loose, 1000);
}

TEST(LidarMesh, FittedNormalsFollowThePlaneUnderRangeNoise) {
  // 2 cm of range noise: a single face's normal (a 3-6 cm edge along the ring) tilts by
  // degrees; the plane fit to its neighbourhood does not.
  const LidarScan scan = stepScene(0.02, 7);
  LidarMeshSettings fit_all, raw;
  fit_all.sampled_faces = 0;  // every face fitted, for the statistics
  raw.smooth_cols = 0;
  const Eigen::Vector3f wall_normal(-1.f, 0.f, 0.f), road_normal(0.f, 0.f, 1.f);
  auto errors = [&](const LidarMesh& mesh, std::vector<double>* wall, std::vector<double>* road) {
    for (const auto& f : mesh.faces) {
      const Surface s = surfaceOf(f, 0.06f);
      if (s == kNearWall) wall->push_back(angleDeg(f.normal, wall_normal));
      if (s == kRoad) road->push_back(angleDeg(f.normal, road_normal));
    }
  };
  std::vector<double> wall_fit, road_fit, wall_raw, road_raw;
  errors(tescalib::buildLidarMesh(scan, fit_all), &wall_fit, &road_fit);
  errors(tescalib::buildLidarMesh(scan, raw), &wall_raw, &road_raw);
  ASSERT_GT(wall_fit.size(), 500u);
  ASSERT_GT(road_fit.size(), 2000u);
  const double wf = median(wall_fit), wr = median(wall_raw);
  const double rf = median(road_fit), rr = median(road_raw);
  RecordProperty("wall_fit_deg", std::to_string(wf));
  RecordProperty("wall_raw_deg", std::to_string(wr));
  RecordProperty("road_fit_deg", std::to_string(rf));
  RecordProperty("road_raw_deg", std::to_string(rr));
  std::printf("median normal error (deg): wall fitted %.2f raw %.2f, road fitted %.2f raw %.2f\n",
              wf, wr, rf, rr);
  EXPECT_GT(wr, 3.0);
  EXPECT_LT(wf, 2.0);
  EXPECT_LT(wf, 0.3 * wr);
  EXPECT_LT(rf, 0.5 * rr);
}

TEST(LidarMesh, NormalsAreFittedForTheSampleTheSolversDrawFrom) {
  using tescalib::evenlyStrided;
  EXPECT_EQ(evenlyStrided(10, 4), (std::vector<size_t>{0, 2, 5, 7}));
  EXPECT_EQ(evenlyStrided(3, 5), (std::vector<size_t>{0, 1, 2}));
  EXPECT_TRUE(evenlyStrided(10, 0).empty());
  EXPECT_TRUE(evenlyStrided(0, 4).empty());

  const LidarScan scan = stepScene(0.02, 7);
  LidarMeshSettings all, raw;
  all.sampled_faces = 0;
  raw.smooth_cols = 0;
  const LidarMesh sampled = tescalib::buildLidarMesh(scan, LidarMeshSettings{});
  const LidarMesh fitted = tescalib::buildLidarMesh(scan, all);
  const LidarMesh unfitted = tescalib::buildLidarMesh(scan, raw);
  const size_t n = sampled.faces.size();
  ASSERT_GT(n, 20000u);
  ASSERT_EQ(fitted.faces.size(), n);
  ASSERT_EQ(unfitted.faces.size(), n);
  EXPECT_EQ(fitted.sample.size(), n);
  ASSERT_EQ(sampled.sample.size(), 4000u);
  // Evenly spread, increasing: the gaps are floor or ceil of n / 4000.
  const size_t lo = n / 4000, hi = (n + 3999) / 4000;
  EXPECT_EQ(sampled.sample.front(), 0u);
  for (size_t j = 1; j < sampled.sample.size(); ++j) {
    const size_t gap = sampled.sample[j] - sampled.sample[j - 1];
    ASSERT_TRUE(gap == lo || gap == hi) << "gap " << gap << " at " << j;
  }
  // The sample's normals are exactly those of the fully fitted mesh; the rest keep their own.
  std::vector<bool> in_sample(n, false);
  for (uint32_t f : sampled.sample) in_sample[f] = true;
  int differs_from_own = 0;
  for (size_t f = 0; f < n; ++f) {
    ASSERT_EQ(sampled.faces[f].centroid, fitted.faces[f].centroid);
    const Eigen::Vector3f& expected =
        in_sample[f] ? fitted.faces[f].normal : unfitted.faces[f].normal;
    ASSERT_EQ(sampled.faces[f].normal, expected) << "face " << f;
    if (in_sample[f] && angleDeg(sampled.faces[f].normal, unfitted.faces[f].normal) > 1.0)
      ++differs_from_own;
  }
  EXPECT_GT(differs_from_own, 2000);  // the fit does change most of the sample
  // A solver asking for fewer faces gets an even part of the sample, for more the whole sample.
  const std::vector<size_t> coarse = tescalib::sampleFaces(sampled, 750);
  ASSERT_EQ(coarse.size(), 750u);
  for (size_t f : coarse) EXPECT_TRUE(in_sample[f]);
  EXPECT_EQ(tescalib::sampleFaces(sampled, 10000).size(), 4000u);
}

TEST(LidarMesh, AConsistentSampleDoesNotDependOnTheViewCone) {
  // Two meshes of one scan, kept within 60 deg of axes 3 deg apart (two initial guesses), with
  // `consistent_sample`: of the faces both meshes hold, those in one's sample are in the other's.
  // The default evenly strided sample of the faces in view shares 1021 of 3909: the stride shifts
  // with the faces the other cone lets in or leaves out.
  const LidarScan scan = stepScene(0.02, 3);
  LidarMeshSettings a, b;
  a.view_half_angle_deg = b.view_half_angle_deg = 60;
  a.consistent_sample = b.consistent_sample = true;
  a.view_axis = Eigen::Vector3d::UnitX();
  b.view_axis = Eigen::AngleAxisd(3.0 / kDegPerRad, Eigen::Vector3d::UnitZ()) * a.view_axis;
  const LidarMesh ma = tescalib::buildLidarMesh(scan, a), mb = tescalib::buildLidarMesh(scan, b);
  ASSERT_GT(ma.faces.size(), 8000u);
  ASSERT_EQ(ma.sample.size(), 4000u);
  ASSERT_EQ(mb.sample.size(), 4000u);
  std::set<uint32_t> keys_b, sample_b;
  for (const auto& f : mb.faces) keys_b.insert(f.key);
  for (uint32_t i : mb.sample) sample_b.insert(mb.faces[i].key);
  int shared = 0, in_both_samples = 0;
  for (uint32_t i : ma.sample) {
    if (!keys_b.count(ma.faces[i].key)) continue;
    ++shared;
    if (sample_b.count(ma.faces[i].key)) ++in_both_samples;
  }
  std::printf("faces %zu / %zu; of A's sample %d are in B's mesh, %d in B's sample\n",
              ma.faces.size(), mb.faces.size(), shared, in_both_samples);
  EXPECT_GT(shared, 3700);
  EXPECT_GT(in_both_samples, 0.95 * shared);
  // Keys are unique: ring, azimuth bin, triangle.
  std::set<uint32_t> keys_a;
  for (const auto& f : ma.faces) keys_a.insert(f.key);
  EXPECT_EQ(keys_a.size(), ma.faces.size());
  // Spread like a stride over the whole turn: increasing, no gap wider than a few strides, and a
  // solver asking for fewer faces gets a consistent part of the sample.
  LidarMeshSettings whole;
  whole.consistent_sample = true;
  const LidarMesh mw = tescalib::buildLidarMesh(scan, whole);
  const size_t n = mw.faces.size();
  ASSERT_EQ(mw.sample.size(), 4000u);
  size_t widest = 0;
  for (size_t j = 1; j < mw.sample.size(); ++j) {
    ASSERT_GT(mw.sample[j], mw.sample[j - 1]) << j;
    widest = std::max<size_t>(widest, mw.sample[j] - mw.sample[j - 1]);
  }
  std::printf("faces %zu, widest gap in the consistent sample %zu (n / 4000 = %.1f)\n", n, widest,
              n / 4000.0);
  EXPECT_LT(widest, 8 * n / 4000);
  const std::vector<size_t> coarse = tescalib::sampleFaces(mw, 750);
  ASSERT_EQ(coarse.size(), 750u);
  const std::set<uint32_t> in_sample(mw.sample.begin(), mw.sample.end());
  for (size_t f : coarse) EXPECT_TRUE(in_sample.count(static_cast<uint32_t>(f)));
  EXPECT_EQ(coarse, tescalib::consistentSample(
                        mw.faces, std::vector<size_t>(mw.sample.begin(), mw.sample.end()), 750));
}

// Faces with keys only (ring << 16 | azimuth position), `rings` x `positions`: what
// consistentSample reads.
std::vector<tescalib::MeshFace> keyedFaces(int rings, int positions) {
  std::vector<tescalib::MeshFace> faces;
  for (int r = 0; r < rings; ++r)
    for (int p = 0; p < positions; ++p) {
      faces.emplace_back();
      faces.back().key = static_cast<uint32_t>(r) << 16 | static_cast<uint32_t>(p);
    }
  return faces;
}

TEST(LidarMesh, AConsistentSampleOfASparseSampleIsStratified) {
  using tescalib::consistentSample;
  const std::vector<tescalib::MeshFace> faces = keyedFaces(4, 4096);
  std::vector<size_t> all(faces.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  // Edge cases: nothing asked, or no more candidates than asked (returned as they are).
  EXPECT_TRUE(consistentSample(faces, all, 0).empty());
  EXPECT_TRUE(consistentSample(faces, all, -3).empty());
  const std::vector<size_t> few = {7, 3, 4100};
  EXPECT_EQ(consistentSample(faces, few, 3), few);
  EXPECT_EQ(consistentSample(faces, few, 10), few);
  // Every 8th position of each ring (2048 candidates), 256 asked: one face from each run of 64
  // positions. A rule that set the runs by the number of candidates (2048 / 8 >= 256: runs of 8,
  // one candidate each) drew the 256 lowest hashes anywhere, leaving runs of 64 empty.
  std::vector<size_t> sparse;
  for (size_t i = 0; i < all.size(); i += 8) sparse.push_back(i);
  const std::vector<size_t> drawn = consistentSample(faces, sparse, 256);
  ASSERT_EQ(drawn.size(), 256u);
  std::vector<int> per_run(4 * 64, 0);
  for (size_t f : drawn) {
    EXPECT_EQ(f % 8, 0u) << f;  // a candidate
    ++per_run[(faces[f].key >> 16) * 64 + (faces[f].key & 0xFFFFu) / 64];
  }
  EXPECT_EQ(std::count(per_run.begin(), per_run.end(), 1), 256);
  // The order of the candidates does not matter.
  std::vector<size_t> shuffled = sparse;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(5));
  EXPECT_EQ(consistentSample(faces, shuffled, 256), drawn);
  // A draw from a sample nests: 1024 from the 4096-face sample (one per run of 4) are the 1024
  // drawn from every face (one per run of 16), as sampleFaces relies on.
  const std::vector<size_t> sample = consistentSample(faces, all, 4096);
  ASSERT_EQ(sample.size(), 4096u);
  EXPECT_EQ(consistentSample(faces, sample, 1024), consistentSample(faces, all, 1024));
}

// One revolution of a 16-ring sensor (elevations -15..+15 deg, 2 deg apart, as a VLP-16; 1800
// returns per ring): `range(d)` is the distance along the unit ray d to the scene (rays beyond
// 80 m or with an infinite range return nothing).
LidarScan sixteenRingScan(const std::function<double(const Eigen::Vector3d&)>& range) {
  LidarScan scan;
  const int rings = 16, per_ring = 1800;
  for (int r = 0; r < rings; ++r) {
    const double elev = (-15.0 + 2.0 * r) / kDegPerRad;
    for (int k = 0; k < per_ring; ++k) {
      const double az = 2 * M_PI * (k + 0.5) / per_ring - M_PI;
      const Eigen::Vector3d d(std::cos(elev) * std::cos(az), std::cos(elev) * std::sin(az),
                              std::sin(elev));
      const double t = range(d);
      if (!(t <= 80.0)) continue;
      tescalib::LidarPoint lp;
      lp.x = float(t * d.x()), lp.y = float(t * d.y()), lp.z = float(t * d.z());
      lp.ring = uint16_t(r);
      scan.push_back(lp);
    }
  }
  return scan;
}

// A 16-ring sensor (elevations -15..+15 deg, 2 deg apart, as a VLP-16) over a flat road with a
// 15 cm kerb: left of y = -3 m the ground is a pavement 15 cm higher. Rings 2 deg apart put the
// road's rings 0.5-2 m apart at 5-9 m, far more than the 6 % of the range a face's edge may
// span between a 64-ring sensor's rings.
TEST(LidarMesh, SparseRingsKeepTheRoadButNoFaceBridgesAKerb) {
  const float kerb = 0.15f;
  const LidarScan scan = sixteenRingScan([&](const Eigen::Vector3d& d) {
    if (d.z() >= 0) return std::numeric_limits<double>::infinity();
    const double t = -kHeight / d.z();
    return (t * d).y() < -3.0 ? -(kHeight - kerb) / d.z() : t;  // left of y = -3: the pavement
  });
  const LidarMesh mesh = tescalib::buildLidarMesh(scan, LidarMeshSettings{});
  int road_5_to_9 = 0, bridges = 0;
  for (const auto& f : mesh.faces) {
    auto level = [&](const Eigen::Vector3f& v) {
      return std::fabs(v.z() + kHeight) < 0.01f          ? 0
             : std::fabs(v.z() + kHeight - kerb) < 0.01f ? 1
                                                         : 2;
    };
    const int la = level(f.a), lb = level(f.b), lc = level(f.c);
    const float range = f.centroid.norm();
    if (la == 0 && lb == 0 && lc == 0 && range > 5.f && range < 9.f) ++road_5_to_9;
    // A face with vertices on both levels and a ring-to-ring edge: it cuts through the kerb,
    // its plane tilted, its centroid centimetres off either surface.
    const float longest = std::max({(f.a - f.b).norm(), (f.b - f.c).norm(), (f.c - f.a).norm()});
    if (std::min({la, lb, lc}) == 0 && std::max({la, lb, lc}) == 1 && longest > 0.06f * range)
      ++bridges;
  }
  // Rings at -15..-11 deg reach the road 6.5-8.9 m away (incidence 75-79 deg): meshed, as the
  // road closer in. A ring-to-ring edge there is 9-23 % of the range.
  EXPECT_GT(road_5_to_9, 4000);
  EXPECT_EQ(bridges, 0);
}

// The same 16-ring sensor facing the back of a car 13.8 m ahead (y = -1..1 m, 0.45..1.4 m above
// the road), optionally with a wall 30 m ahead behind it: the ring at -7 deg passes under the
// car's body to the road at 14.09 m, the rings at -5 and -3 deg hit its back (0.52 and 1.01 m up).
LidarScan carScene(bool wall_behind) {
  const double x0 = 13.8, y_half = 1.0, z_lo = -kHeight + 0.45, z_hi = -kHeight + 1.4;
  return sixteenRingScan([&](const Eigen::Vector3d& d) {
    double t = d.z() < 0 ? -kHeight / d.z() : std::numeric_limits<double>::infinity();
    if (d.x() > 0) {
      const double tb = x0 / d.x();  // the car's back
      const Eigen::Vector3d p = tb * d;
      if (std::fabs(p.y()) <= y_half && p.z() >= z_lo && p.z() <= z_hi && tb < t) t = tb;
      if (wall_behind) t = std::min(t, 30.0 / d.x());
    }
    return t;
  });
}

// A face joining the road under the car to its back has edges of 0.6 m, within the 6 % of the
// range a dense scan allows, but is a fold between two surfaces, 29 deg off the back and 61 deg
// off the road, its centroid 10-35 cm off either. The back itself is seen by one ring pair only:
// it stays, also with a wall behind it (then both rings beyond its pair leave its plane).
TEST(LidarMesh, NoFaceFoldsFromTheRoadUpACarsBack) {
  for (bool wall_behind : {false, true}) {
    SCOPED_TRACE(wall_behind ? "wall behind the car" : "open road behind the car");
    const LidarMesh mesh = tescalib::buildLidarMesh(carScene(wall_behind), LidarMeshSettings{});
    int folds = 0, back = 0, road_before_car = 0;
    for (const auto& f : mesh.faces) {
      auto on_road = [&](const Eigen::Vector3f& v) { return std::fabs(v.z() + kHeight) < 0.01f; };
      auto on_back = [&](const Eigen::Vector3f& v) { return std::fabs(v.x() - 13.8f) < 0.01f; };
      const int road = on_road(f.a) + on_road(f.b) + on_road(f.c);
      const int car = on_back(f.a) + on_back(f.b) + on_back(f.c);
      if (road > 0 && car > 0) ++folds;
      if (car == 3) ++back;
      if (road == 3 && std::fabs(f.centroid.y()) < 1.f && f.centroid.x() > 8.f) ++road_before_car;
    }
    EXPECT_EQ(folds, 0);
    // The car's back (one ring pair over 8.3 deg of azimuth: 41 bins, 82 faces) stays, and so does
    // the road before it (8-10 m: beyond 10 m a 16-ring sensor sees the road beyond 80 deg of
    // incidence, too grazing to mesh).
    EXPECT_GT(back, 75);
    EXPECT_GT(road_before_car, 50);
  }
  // The scene upside down (a ceiling 1.73 m above, the car hanging from it; rings renumbered from
  // the lowest): the folds are then found from the rings above them.
  LidarScan mirrored = carScene(false);
  for (auto& p : mirrored) p.z = -p.z, p.ring = uint16_t(15 - p.ring);
  int mirrored_folds = 0, mirrored_back = 0, ceiling_before_car = 0;
  for (const auto& f : tescalib::buildLidarMesh(mirrored, LidarMeshSettings{}).faces) {
    int ceiling = 0, car = 0;
    for (const Eigen::Vector3f* v : {&f.a, &f.b, &f.c})
      ceiling += std::fabs(v->z() - kHeight) < 0.01f, car += std::fabs(v->x() - 13.8f) < 0.01f;
    mirrored_folds += ceiling > 0 && car > 0;
    mirrored_back += car == 3;
    ceiling_before_car += ceiling == 3 && std::fabs(f.centroid.y()) < 1.f && f.centroid.x() > 8.f;
  }
  EXPECT_EQ(mirrored_folds, 0);
  // ... and it was meshed as the scene the right way up (no folds because no faces would pass).
  EXPECT_GT(mirrored_back, 75);
  EXPECT_GT(ceiling_before_car, 50);
  // In scans of fold_below_rings rings or more (48 by default; 0: every scan) folds stay.
  LidarMeshSettings dense_only;
  dense_only.fold_below_rings = 0;
  int kept_folds = 0;
  for (const auto& f : tescalib::buildLidarMesh(carScene(false), dense_only).faces) {
    int road = 0, car = 0;
    for (const Eigen::Vector3f* v : {&f.a, &f.b, &f.c})
      road += std::fabs(v->z() + kHeight) < 0.01f, car += std::fabs(v->x() - 13.8f) < 0.01f;
    kept_folds += road > 0 && car > 0;
  }
  // Both triangles of each of the car's 41 azimuth bins between the ring passing under it and
  // the ring on its back (82), give or take a bin at either edge.
  EXPECT_GE(kept_folds, 80);
  EXPECT_LE(kept_folds, 86);
}

TEST(LidarMesh, KeepEveryNthRingRenumbersTheKeptRings) {
  LidarScan scan;
  for (int r = 0; r < 8; ++r) {
    tescalib::LidarPoint p;
    p.x = float(r), p.ring = uint16_t(r);
    scan.push_back(p);
  }
  LidarScan same = scan;
  tescalib::keepEveryNthRing(&same, 1);
  EXPECT_EQ(same.size(), 8u);
  tescalib::keepEveryNthRing(&scan, 4);
  ASSERT_EQ(scan.size(), 2u);
  EXPECT_EQ(scan[0].ring, 0);
  EXPECT_EQ(scan[1].ring, 1);
  EXPECT_EQ(scan[1].x, 4.f);  // ring 4 is the second kept
}

TEST(LidarMesh, AScanCroppedToTheCamerasViewIsMeshedAsFinelyAsAFullTurn) {
  // A driver can crop its scans to a sector (velodyne_pointcloud's view_width): then the densest
  // ring's returns cover that sector only. Counted over the whole turn they would make bins 3.6
  // beams wide for a 100 deg sector, each keeping one return of three or four.
  const LidarScan full = stepScene(0.0, 1);
  LidarScan cropped;
  for (const auto& p : full)
    if (std::fabs(std::atan2(p.y, p.x)) < 50.0 / kDegPerRad) cropped.push_back(p);
  auto facesAhead = [](const LidarMesh& mesh) {
    int n = 0;
    for (const auto& f : mesh.faces)
      n += std::fabs(std::atan2(f.centroid.y(), f.centroid.x())) < 45.0 / kDegPerRad;
    return n;
  };
  LidarMeshSettings s;
  s.sampled_faces = 0;
  const int from_full = facesAhead(tescalib::buildLidarMesh(full, s));
  const int from_cropped = facesAhead(tescalib::buildLidarMesh(cropped, s));
  std::printf("faces within 45 deg ahead: full turn %d, scan cropped to 100 deg %d\n", from_full,
              from_cropped);
  ASSERT_GT(from_full, 10000);
  EXPECT_GT(from_cropped, 0.95 * from_full);
  EXPECT_LT(from_cropped, 1.05 * from_full);
}

TEST(LidarMesh, AWideNormalWindowOnASparseRingReadsEachPointOnce) {
  // 4 rings of 16 returns: a 16-column range image; smooth_cols 40 (allowed by azimuth_bins / 4)
  // must not make the fit's window wrap past the row and read before the grid.
  LidarScan scan;
  for (int r = 0; r < 4; ++r)
    for (int k = 0; k < 16; ++k) {
      const double az = 2 * M_PI * (k + 0.5) / 16 - M_PI, elev = (-20.0 + 2.0 * r) / kDegPerRad;
      const double t = kHeight / std::sin(-elev);  // the road
      tescalib::LidarPoint p;
      p.x = float(t * std::cos(elev) * std::cos(az));
      p.y = float(t * std::cos(elev) * std::sin(az));
      p.z = float(-kHeight);
      p.ring = uint16_t(r);
      scan.push_back(p);
    }
  LidarMeshSettings s;
  s.smooth_cols = 40;
  s.sampled_faces = 0;
  s.max_edge_ratio = 1.0;  // sparse: keep the faces
  s.max_edge_abs = 10.0;
  const LidarMesh mesh = tescalib::buildLidarMesh(scan, s);
  ASSERT_FALSE(mesh.faces.empty());
  for (const auto& f : mesh.faces) {
    ASSERT_TRUE(f.normal.allFinite());
    EXPECT_NEAR(std::fabs(f.normal.z()), 1.f, 1e-3f);  // the road's normal
  }
}
