// Tests of the generator's real sensors' errors (sim/sensor_realism.h): sizes and presets, the
// per-drive draw, and that each source does to the data what it says: the right camera's residual
// rotation shows in the rows, per-laser range offsets and elevation errors in the scan, the time
// offset in the scan's pose, blur, vignetting and lens distortion in the images.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/kitti_calib.h"
#include "tescalib/core/sim/sensor_realism.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/sim/simulator_lidar.h"
#include "tescalib/core/sim/simulator_random.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/stereo/stereo_cloud.h"
#include "test_util.h"

using namespace tescalib;
using tescalib::sim::RealismDraw;
using tescalib::sim::RealismSizes;
using tescalib_test::TempDir;
namespace fs = std::filesystem;

namespace {

SimOptions small(uint64_t seed, const std::string& realism_set) {
  SimOptions o;
  o.frames = 1;
  o.seed = seed;
  o.noise = NoiseLevel::kNone;
  EXPECT_EQ(o.realism.set(realism_set), "");
  return o;
}

double rms(const std::vector<double>& v) {
  return std::sqrt(std::inner_product(v.begin(), v.end(), v.begin(), 0.0) / v.size());
}

/// Variance of the Laplacian of the grey image (a sharpness measure).
double sharpness(const cv::Mat& bgr) {
  cv::Mat g, lap;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  cv::Laplacian(g, lap, CV_64F);
  cv::Scalar mean, sd;
  cv::meanStdDev(lap, mean, sd);
  return sd[0] * sd[0];
}

}  // namespace

TEST(SensorRealism, PresetsAndAssignments) {
  RealismSizes s;
  EXPECT_TRUE(s.none());
  ASSERT_TRUE(RealismSizes::preset("kitti", &s));
  EXPECT_FALSE(s.none());
  EXPECT_GT(s.right_rotation_deg, 0);
  EXPECT_LT(s.asphalt_texture, 1);
  EXPECT_FALSE(RealismSizes::preset("mars", &s));
  ASSERT_TRUE(RealismSizes::preset("none", &s));
  EXPECT_TRUE(s.none());
  EXPECT_EQ(s.set("range_scale=0.01,right_blur_px=0.7"), "");
  EXPECT_DOUBLE_EQ(s.range_scale, 0.01);
  EXPECT_DOUBLE_EQ(s.right_blur_px, 0.7);
  EXPECT_NE(s.set("range_scal=0.01").find("not KEY=VALUE"), std::string::npos);
  EXPECT_NE(s.set("range_scale=abc").find("range"), std::string::npos);
  EXPECT_NE(s.set("asphalt_texture=2").find("asphalt_texture"), std::string::npos);
  EXPECT_NE(s.set("lens_k1=nan").find("lens_k1"), std::string::npos);
  EXPECT_NE(s.yaml().find("realism_size_range_scale: 0.01"), std::string::npos);
}

TEST(SensorRealism, DrawIsExactWhenOffAndSizedWhenOn) {
  const RealismDraw off = sim::drawRealism(RealismSizes{}, 3, 64);
  EXPECT_FALSE(off.movesRightCamera());
  EXPECT_EQ(off.range_scale, 1.0);
  EXPECT_EQ(off.lidar_time_offset_s, 0.0);
  for (double v : off.laser_range_offset_m) EXPECT_EQ(v, 0.0);
  RealismSizes k;
  ASSERT_TRUE(RealismSizes::preset("kitti", &k));
  const RealismDraw a = sim::drawRealism(k, 3, 64), again = sim::drawRealism(k, 3, 64),
                    b = sim::drawRealism(k, 4, 64);
  EXPECT_TRUE(a.movesRightCamera());
  EXPECT_EQ(a.laser_range_offset_m, again.laser_range_offset_m);  // from the seed alone
  EXPECT_NE(a.laser_range_offset_m, b.laser_range_offset_m);
  // 64 lasers: the rms of the draws is the size within about 25 %.
  EXPECT_NEAR(rms(a.laser_range_offset_m), k.laser_range_offset_m, 0.25 * k.laser_range_offset_m);
  EXPECT_NEAR(rms(a.laser_elevation_rad) * kDegPerRad, k.laser_elevation_deg,
              0.25 * k.laser_elevation_deg);
  EXPECT_GE(a.right_blur_px, 0.5 * k.right_blur_px);
  EXPECT_LE(a.right_blur_px, 1.5 * k.right_blur_px);
  // The true right camera: the nominal one turned by the draw and its baseline scaled.
  Eigen::Isometry3d nominal = Eigen::Isometry3d::Identity();
  nominal.translation() = Eigen::Vector3d(-0.54, 0, 0);
  const Eigen::Isometry3d T = a.trueRightLeft(nominal);
  const Eigen::Vector3d centre = -(T.linear().transpose() * T.translation());
  EXPECT_NEAR(centre.x(), 0.54 * a.baseline_scale, 1e-12);
  EXPECT_NEAR(centre.tail<2>().norm(), 0, 1e-12);
  EXPECT_TRUE(T.linear().isApprox(a.right_rotation));
}

TEST(SensorRealism, TrueRightCameraIsWrittenAndShowsInTheRows) {
  // A residual pitch of the right camera: its rows sit fy * angle lower than calib.txt says,
  // and where calib_true.txt says.
  SimOptions o = small(21, "right_rotation_deg=0.03");
  TempDir dir;
  const Simulator sim(o);
  sim.writeSequence(dir.str());
  ASSERT_TRUE(fs::exists(dir.path / "calib_true.txt"));
  const StereoRig nominal = rigFromOdometryCalib(readKittiOdometryCalib(dir.str() + "/calib.txt"));
  const StereoRig truth =
      rigFromOdometryCalib(readKittiOdometryCalib(dir.str() + "/calib_true.txt"));
  EXPECT_LT(poseError(nominal.T_right_left, Simulator(small(21, "")).rig().T_right_left).norm(),
            1e-12);
  EXPECT_LT(poseError(truth.T_right_left, sim.trueRig().T_right_left).norm(), 1e-9);
  const Eigen::AngleAxisd aa(sim.realism().right_rotation);
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  const Frame f = sim.renderFrame(0);
  const StereoCloud cloud = computeStereoCloud(f.left, f.right, nominal, nominal.T_right_left);
  const VerticalAlignment at_nominal =
      verticalAlignment(f.left, f.right, cloud, nominal, nominal.T_right_left);
  const VerticalAlignment at_truth =
      verticalAlignment(f.left, f.right, cloud, nominal, truth.T_right_left);
  // Turning the right camera by +w.x (about its x axis) moves its image content up by fy w.x.
  EXPECT_NEAR(at_nominal.offset_px, -nominal.right.fy * w.x(), 0.08);
  EXPECT_LT(std::fabs(at_truth.offset_px), 0.08);
  std::ifstream info(dir.path / "sim_info.txt");
  const std::string text((std::istreambuf_iterator<char>(info)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("realism_right_rotation_deg: ["), std::string::npos);
  // Without realism there is no calib_true.txt and the clean drive's bytes stay.
  TempDir clean;
  simulateSequence(small(21, ""), clean.str());
  EXPECT_FALSE(fs::exists(clean.path / "calib_true.txt"));
}

TEST(SensorRealism, RowsMeasuredOnOnePairGiveTheRightCamerasPitchAndRoll) {
  // The pair matched at calib.txt's extrinsic, its rows measured, and the extrinsic that explains
  // them (rowAlignedExtrinsic): its pitch and roll against the true right camera's, and the rows
  // of the pair matched again with it.
  SimOptions o = small(23, "right_rotation_deg=0.06");
  const Simulator sim(o);
  const StereoRig nominal = Simulator(small(23, "")).rig();
  const Frame f = sim.renderFrame(0);
  const StereoCloud cloud = computeStereoCloud(f.left, f.right, nominal, nominal.T_right_left);
  const VerticalAlignment rows =
      verticalAlignment(f.left, f.right, cloud, nominal, nominal.T_right_left);
  const Eigen::Isometry3d aligned =
      rowAlignedExtrinsic(nominal.T_right_left, rows, nominal.right.fy);
  const Eigen::AngleAxisd truth(sim.trueRig().T_right_left.linear() *
                                nominal.T_right_left.linear().transpose());
  const Eigen::AngleAxisd found(aligned.linear() * nominal.T_right_left.linear().transpose());
  const Eigen::Vector3d w_true = truth.angle() * truth.axis() * kDegPerRad,
                        w_found = found.angle() * found.axis() * kDegPerRad;
  EXPECT_GT(std::fabs(w_true.x()), 0.01) << "the drawn pitch is too small to test with";
  EXPECT_NEAR(w_found.x(), w_true.x(), 0.006) << "deg";
  EXPECT_NEAR(w_found.z(), w_true.z(), 0.02) << "deg";
  EXPECT_EQ(w_found.y(), 0.0);  // a yaw is a disparity offset, not a row offset
  const StereoCloud again = computeStereoCloud(f.left, f.right, nominal, aligned);
  const VerticalAlignment after = verticalAlignment(f.left, f.right, again, nominal, aligned);
  EXPECT_LT(std::fabs(after.offset_px), 0.05);
  EXPECT_LT(std::fabs(after.offset_px), 0.3 * std::fabs(rows.offset_px));
  // The correction moves the outermost rows by |offset| + |slope| x_max: more than the re-aligned
  // pair's rows still show.
  const double x_max =
      std::max(nominal.left.cx, nominal.left.width - nominal.left.cx) / nominal.left.fx;
  EXPECT_DOUBLE_EQ(largestRowCorrectionPx(rows, nominal.left),
                   std::fabs(rows.offset_px) + std::fabs(rows.slope_x_px) * x_max);
  EXPECT_GT(largestRowCorrectionPx(rows, nominal.left), 0.05);
  EXPECT_LT(largestRowCorrectionPx(after, nominal.left),
            0.5 * largestRowCorrectionPx(rows, nominal.left));
  EXPECT_TRUE(
      std::isnan(largestRowCorrectionPx(VerticalAlignment{0, 0, NAN, NAN, NAN, 0}, nominal.left)));
}

TEST(SensorRealism, LasersRangeOffsetsScaleAndElevationErrors) {
  SimOptions o = small(5, "");
  o.scenario = Scenario::kHighway;
  const LidarScan clean = Simulator(o).renderScan(0);
  ASSERT_EQ(o.realism.set("laser_range_offset_m=0.05,range_scale=0.01"), "");
  const Simulator off(o);
  const LidarScan shifted = off.renderScan(0);
  const RealismDraw& d = off.realism();
  // Beams by (ring, azimuth step): the same beam hits the same point, reported farther.
  const auto key = [](const LidarPoint& p) {
    const double az = std::atan2(p.y, p.x);
    return p.ring * 100000 + static_cast<int>(std::lround((az < 0 ? az + 2 * M_PI : az) * 1000));
  };
  std::map<int, double> clean_range;
  for (const LidarPoint& p : clean) clean_range[key(p)] = Eigen::Vector3f(p.x, p.y, p.z).norm();
  double worst = 0;
  int matched = 0;
  for (const LidarPoint& p : shifted) {
    const auto it = clean_range.find(key(p));
    if (it == clean_range.end()) continue;
    const double expected = d.range_scale * it->second + d.laser_range_offset_m[p.ring];
    worst = std::max(worst, std::fabs(Eigen::Vector3f(p.x, p.y, p.z).norm() - expected));
    ++matched;
  }
  EXPECT_GT(matched, 100000);
  EXPECT_LT(worst, 1e-3);
  // An elevation error: the beam meets the flat road at another range but is reported along the
  // nominal direction, so a road ring's ranges scale by sin(el) / sin(el + e).
  o.realism = RealismSizes{};
  ASSERT_EQ(o.realism.set("laser_elevation_deg=0.2"), "");
  const Simulator tilted(o);
  const LidarScan t = tilted.renderScan(0);
  const int ring = 5;  // about -22 deg: the road a few metres ahead
  const double el = sim::LidarModel::hdl64e().elevation_deg[ring] / kDegPerRad;
  const double e = tilted.realism().laser_elevation_rad[ring];
  std::vector<double> ratio;
  for (size_t i = 0, j = 0; i < clean.size() && j < t.size();) {
    if (clean[i].ring != ring) {
      ++i;
      continue;
    }
    while (j < t.size() && t[j].ring != ring) ++j;
    if (j >= t.size()) break;
    ratio.push_back(std::hypot(t[j].x, t[j].y) / std::hypot(clean[i].x, clean[i].y));
    ++i, ++j;
  }
  ASSERT_GT(ratio.size(), 500u);
  std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
  EXPECT_NEAR(ratio[ratio.size() / 2], std::sin(el) / std::sin(el + e), 0.002);
  EXPECT_GT(std::fabs(std::sin(el) / std::sin(el + e) - 1), 0.004);  // the error is visible
}

TEST(SensorRealism, MixedPixelsLieBetweenTheEdgesTwoSurfaces) {
  SimOptions o = small(6, "");
  const LidarScan clean = Simulator(o).renderScan(0);
  ASSERT_EQ(o.realism.set("mixed_pixel_fraction=1"), "");
  const LidarScan mixed = Simulator(o).renderScan(0);
  ASSERT_EQ(mixed.size(), clean.size());
  int moved = 0, farther = 0;
  for (size_t i = 0; i < clean.size(); ++i) {
    const double a = Eigen::Vector3f(clean[i].x, clean[i].y, clean[i].z).norm();
    const double b = Eigen::Vector3f(mixed[i].x, mixed[i].y, mixed[i].z).norm();
    EXPECT_NEAR((mixed[i].x * a) / b, clean[i].x, 1e-3);  // along the same beam
    if (std::fabs(b - a) > 1e-4) ++moved, farther += b > a;
  }
  // Only beams at depth edges (a few per cent of an urban scan), both ways.
  EXPECT_GT(moved, 200);
  EXPECT_LT(moved, 0.08 * clean.size());
  EXPECT_GT(farther, moved / 5);
}

TEST(SensorRealism, TimeOffsetTakesTheScanLater) {
  SimOptions o = small(8, "lidar_time_offset_s=0.02");
  const Simulator late(o);
  const double dt = late.realism().lidar_time_offset_s;
  ASSERT_GT(std::fabs(dt), 1e-4);
  const LidarScan scan = late.renderScan(0);
  sim::LidarNoise none;
  none.range_sigma = none.intensity_sigma = 0;
  const LidarScan expected =
      sim::simulateLidarScan(late.world(), late.worldFromLidarAt(dt), sim::LidarModel::hdl64e(),
                             none, sim::subSeed(o.seed, 3), 1);
  ASSERT_EQ(scan.size(), expected.size());
  for (size_t i = 0; i < scan.size(); i += 97) EXPECT_FLOAT_EQ(scan[i].x, expected[i].x);
}

TEST(SensorRealism, BlurVignettingAndLensDistortionShowInTheImages) {
  SimOptions o = small(9, "");
  const Frame clean = Simulator(o).renderFrame(0);
  ASSERT_EQ(o.realism.set("right_blur_px=0.8,vignetting=0.3,lens_k1=0.01"), "");
  const Simulator real(o);
  const Frame f = real.renderFrame(0);
  const RealismDraw& d = real.realism();
  const StereoRig& rig = real.rig();
  // Blur: the right image loses sharpness.
  EXPECT_LT(sharpness(f.right) / sharpness(clean.right), 0.8);
  // Vignetting: the corner darker by about the drawn fraction.
  const cv::Rect corner(0, clean.left.rows - 10, 20, 10);  // the road: nothing clipped
  const double ratio = cv::mean(f.left(corner))[1] / cv::mean(clean.left(corner))[1];
  const double du = 10 - rig.left.cx, dv = clean.left.rows - 5 - rig.left.cy;
  const double corner2 =
      rig.left.cx * rig.left.cx + (clean.left.rows - rig.left.cy) * (clean.left.rows - rig.left.cy);
  EXPECT_NEAR(ratio, 1 - d.left_vignetting * (du * du + dv * dv) / corner2, 0.03);
  // Lens distortion: content at normalised x moves by fx x k1 r^2 along x.
  ASSERT_GT(std::fabs(d.lens_k1), 0.003);
  const cv::Rect patch(40, 120, 128, 128);
  cv::Mat a, b;
  cv::cvtColor(clean.left(patch), a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(f.left(patch), b, cv::COLOR_BGR2GRAY);
  a.convertTo(a, CV_64F);
  b.convertTo(b, CV_64F);
  const cv::Point2d shift = cv::phaseCorrelate(a, b);
  const double x = (patch.x + 0.5 * patch.width - rig.left.cx) / rig.left.fx;
  const double y = (patch.y + 0.5 * patch.height - rig.left.cy) / rig.left.fy;
  double xu = x, yu = y;  // where the scene point seen at (x, y) is without distortion
  for (int i = 0; i < 20; ++i) {
    const double f = 1 + d.lens_k1 * (xu * xu + yu * yu);
    xu = x / f, yu = y / f;
  }
  const double expected = rig.left.fx * (x - xu);
  std::cout << "[ lens     ] k1 " << d.lens_k1 << ": shift " << shift.x << " px, expected "
            << expected << " px\n";
  EXPECT_NEAR(shift.x, expected, 0.3 + 0.2 * std::fabs(expected));
}
