// The signatures of the stereo-minus-LiDAR disparity residual (disparity_signatures.h) on a
// synthetic pair: a plane seen by the LiDAR's rings and by a stereo disparity image into which
// known errors are put (an offset and a scale of the disparity, an offset per third of the image,
// a range offset per LiDAR ring, noise and mismatches).
#include <array>
#include <cmath>
#include <functional>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "tescalib/core/eval/disparity_signatures.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"

using namespace tescalib;

namespace {

constexpr int kWidth = 1200, kHeight = 370;
constexpr double kFocal = 720, kBaseline = 0.54;

/// The scene's true disparity at (u, v): a plane, 13-94 px over the pixels the rings see (4-30 m).
double sceneDisparity(double u, double v) { return 12.0 + 0.25 * v + 0.002 * u; }

struct Errors {
  double offset_px = 0;                 ///< added to every stereo disparity
  double scale = 0;                     ///< the stereo disparity is (1 + scale) times the scene's
  std::array<double, 3> third_px{};     ///< added to the stereo disparity in each third
  std::function<double(int)> ring_px;   ///< added to a ring's residual (its LiDAR range)
  std::function<int(int)> ring_points;  ///< points of a ring (150 when not given)
  double noise_px = 0;                  ///< Gaussian noise of the stereo disparity
  double mismatch_fraction = 0;         ///< stereo pixels off by mismatch_px
  double mismatch_px = 0;
};

StereoCloud stereoCloud(const Errors& e, unsigned seed = 5) {
  StereoCloud c;
  c.fx = c.fy = kFocal;
  c.cx = kWidth / 2.0;
  c.cy = kHeight / 2.0;
  c.baseline = kBaseline;
  c.disparity.create(kHeight, kWidth, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) {
      double d = (1 + e.scale) * sceneDisparity(u, v) + e.offset_px + e.noise_px * noise(rng);
      d += e.third_px[std::min(3 * u / kWidth, 2)];
      if (uniform(rng) < e.mismatch_fraction) d += e.mismatch_px;
      c.disparity.at<float>(v, u) = static_cast<float>(d);
    }
  return c;
}

/// 64 rings, ring r along image row 4 + 5 r, its points spread evenly over the columns; each
/// point where the scene is, but at the depth that makes its predicted disparity ring_px less.
LidarScan scan(const Errors& e) {
  LidarScan out;
  for (int r = 0; r < 64; ++r) {
    const int n = e.ring_points ? e.ring_points(r) : 150;
    const double v = 4 + 5 * r;
    for (int k = 0; k < n; ++k) {
      const double u = std::round((k + 0.5) * kWidth / n);
      const double z =
          kFocal * kBaseline / (sceneDisparity(u, v) - (e.ring_px ? e.ring_px(r) : 0.0));
      LidarPoint p;
      p.x = static_cast<float>((u - kWidth / 2.0) * z / kFocal);
      p.y = static_cast<float>((v - kHeight / 2.0) * z / kFocal);
      p.z = static_cast<float>(z);
      p.ring = static_cast<uint16_t>(r);
      out.push_back(p);
    }
  }
  return out;
}

std::vector<DisparitySample> samples(const Errors& e) {
  return disparitySamples(scan(e), stereoCloud(e), Eigen::Isometry3d::Identity());
}

void print(const char* name, const DisparitySignatures& s) {
  std::cout << "[ " << name << " ] thirds " << s.third_median_px[0] << " / " << s.third_median_px[1]
            << " / " << s.third_median_px[2] << " px; ring jump " << s.ring_jump_px << " px over "
            << s.rings << " rings (" << s.ring_pairs << " pairs); fit offset " << s.fit.offset_px
            << " px, scale " << 100 * s.fit.scale << " %, sigma " << s.fit.sigma_px << " px of "
            << s.fit.points << " points\n";
}

}  // namespace

TEST(DisparitySignatures, AnExactPairShowsNone) {
  const DisparitySignatures s = disparitySignatures(samples(Errors{}));
  print("exact", s);
  EXPECT_EQ(s.points, 64 * 150);
  for (int t = 0; t < 3; ++t) {
    EXPECT_NEAR(s.third_points[t], 64 * 50, 64) << "third " << t;
    EXPECT_LT(std::fabs(s.third_median_px[t]), 1e-4) << "third " << t;
  }
  EXPECT_EQ(s.rings, 64);
  EXPECT_EQ(s.ring_pairs, 63);
  EXPECT_LT(s.ring_jump_px, 1e-4);
  EXPECT_LT(s.ring_max_jump_px, 1e-4);
  EXPECT_EQ(s.fit.points, 64 * 150);
  EXPECT_LT(std::fabs(s.fit.offset_px), 1e-4);
  EXPECT_LT(std::fabs(s.fit.scale), 1e-6);
}

// KITTI 04's pair against its LiDAR: about +0.8 % and -0.2 px. Mismatches within 3 px (5 %) pull
// a plain least-squares offset by 0.12 px; those beyond 3 px (3 %) are left out.
TEST(DisparitySignatures, TheFitRecoversADisparityOffsetAndScaleDespiteMismatches) {
  Errors e;
  e.offset_px = -0.2;
  e.scale = 0.008;
  e.noise_px = 0.15;
  e.mismatch_fraction = 0.05;
  e.mismatch_px = 2.5;
  std::vector<DisparitySample> all = samples(e);
  Errors far = e;
  far.mismatch_fraction = 0.03;
  far.mismatch_px = 8.0;
  const std::vector<DisparitySample> beyond = samples(far);
  all.insert(all.end(), beyond.begin(), beyond.end());  // two frames pooled
  const DisparitySignatures s = disparitySignatures(all);
  print("fit", s);
  const DisparityResidual r = disparityResidualOf(all);
  EXPECT_EQ(s.points, r.points);
  EXPECT_NEAR(s.points, 2 * 64 * 150 - 0.03 * 64 * 150, 100);
  EXPECT_EQ(s.fit.points, s.points);
  EXPECT_NEAR(s.fit.offset_px, -0.2, 0.03);
  EXPECT_NEAR(s.fit.scale, 0.008, 0.0005);
  EXPECT_NEAR(s.fit.sigma_px, 0.15, 0.03);
  // The scale is seen at every depth: +0.8 % of 13-94 px on top of the offset.
  for (int b = 1; b < DisparityResidual::kBins; ++b) {
    ASSERT_GT(r.bin_points[b], 300) << "bin " << b;
    EXPECT_LT(r.bin_median_px[b], r.bin_median_px[b - 1]) << "bin " << b;
  }
}

TEST(DisparitySignatures, AColumnDependentOffsetShowsInTheThirds) {
  Errors e;
  e.third_px = {0.3, 0.0, -0.2};
  e.noise_px = 0.1;
  const DisparitySignatures s = disparitySignatures(samples(e));
  print("thirds", s);
  for (int t = 0; t < 3; ++t) {
    EXPECT_NEAR(s.third_points[t], 64 * 50, 64) << "third " << t;
    EXPECT_NEAR(s.third_median_px[t], e.third_px[t], 0.02) << "third " << t;
  }
  EXPECT_LT(s.ring_jump_px, 0.05);
}

// A HDL-64's lasers each have their own range offset: alternating rings 0.5 px apart, as KITTI's
// nearest rings show, and rings 50 and 51 at +1.2 and +0.8 px (the largest jump: 51 to 52).
// Rings 0-3 and 40 have too few points to count (and a disparity 2.5 px off, which would show).
TEST(DisparitySignatures, APerRingOffsetGivesItsRingToRingJump) {
  const auto sparse = [](int r) { return r < 4 || r == 40; };
  Errors e;
  e.noise_px = 0.1;
  e.ring_px = [&](int r) {
    return sparse(r) ? 2.5 : r == 50 ? 1.2 : r == 51 ? 0.8 : 0.5 * (r % 2);
  };
  e.ring_points = [&](int r) { return sparse(r) ? DisparitySignatures::kMinRingPoints - 1 : 150; };
  const DisparitySignatures s = disparitySignatures(samples(e));
  print("rings", s);
  EXPECT_EQ(s.rings, 59);
  EXPECT_EQ(s.ring_pairs, 57);  // 4-5 ... 62-63 without 39-40 and 40-41
  EXPECT_NEAR(s.ring_jump_px, 0.5, 0.03);
  ASSERT_EQ(s.ring_median_px.size(), 64u);
  EXPECT_NEAR(s.ring_median_px[4], 0.0, 0.03);
  EXPECT_NEAR(s.ring_median_px[5], 0.5, 0.03);
  EXPECT_EQ(s.ring_median_px[40], 0.0);
  EXPECT_EQ(s.ring_points[40], DisparitySignatures::kMinRingPoints - 1);
  EXPECT_NEAR(s.ring_min_median_px, 0.0, 0.03);
  EXPECT_NEAR(s.ring_max_median_px, 1.2, 0.03);
  EXPECT_NEAR(s.ring_max_jump_px, 0.8, 0.04);
  EXPECT_EQ(s.ring_max_jump_ring, 51);
}
