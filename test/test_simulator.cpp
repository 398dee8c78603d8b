// Tests of the scene generator (tescalib_simulate's library): layout and ring order as KITTI,
// ground truth consistent with what the images show (SGBM disparity, photometric error), noise
// model, determinism, --calib honoured, and the scenarios' character.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/io/sim_info.h"
#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/sim/simulator_camera.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/stereo/stereo_cloud.h"
#include "test_util.h"

using namespace tescalib;
using tescalib_test::TempDir;
namespace fs = std::filesystem;

namespace {

SimOptions options(Scenario scenario, int frames, uint64_t seed = 7) {
  SimOptions o;
  o.scenario = scenario;
  o.frames = frames;
  o.seed = seed;
  return o;
}

/// OpenCV SGBM (128 disparities, block 5) on the grey images; disparity in px, invalid < 0.
cv::Mat sgbmDisparity(const cv::Mat& left, const cv::Mat& right) {
  cv::Mat gl, gr, d16, disp;
  cv::cvtColor(left, gl, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right, gr, cv::COLOR_BGR2GRAY);
  const int block = 5;
  auto sgbm = cv::StereoSGBM::create(0, 128, block, 8 * block * block, 32 * block * block, 1, 63,
                                     10, 100, 2, cv::StereoSGBM::MODE_SGBM_3WAY);
  sgbm->compute(gl, gr, d16);
  d16.convertTo(disp, CV_32F, 1.0 / 16.0);
  return disp;
}

struct DisparityComparison {
  int projected = 0;             ///< LiDAR points inside the matched part of the image
  int valid = 0;                 ///< of those, pixels where SGBM gave a disparity
  double median_abs_diff = 1e9;  ///< median |SGBM - fx B / Z| over valid pixels (px)
};

/// LiDAR points projected with T_cam_lidar versus the SGBM disparity at their pixels.
DisparityComparison compareWithLidar(const LidarScan& scan, const cv::Mat& disp,
                                     const StereoRig& rig, const Eigen::Isometry3d& T_cam_lidar) {
  DisparityComparison out;
  std::vector<double> diffs;
  const double fb = rig.left.fx * rig.baseline();
  for (const auto& p : scan) {
    const Eigen::Vector3d c = T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
    if (c.z() < 3.0) continue;
    const int u = static_cast<int>(std::lround(rig.left.fx * c.x() / c.z() + rig.left.cx));
    const int v = static_cast<int>(std::lround(rig.left.fy * c.y() / c.z() + rig.left.cy));
    if (u < 128 || v < 0 || u >= disp.cols || v >= disp.rows) continue;
    ++out.projected;
    const float d = disp.at<float>(v, u);
    if (d <= 0.f) continue;
    ++out.valid;
    diffs.push_back(std::fabs(d - fb / c.z()));
  }
  if (!diffs.empty()) {
    std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
    out.median_abs_diff = diffs[diffs.size() / 2];
  }
  return out;
}

float bilinear(const cv::Mat& img, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const float a = img.at<float>(y0, x0), b = img.at<float>(y0, x0 + 1);
  const float c = img.at<float>(y0 + 1, x0), d = img.at<float>(y0 + 1, x0 + 1);
  return (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d);
}

/// Mean |I_right(u - d, v) - (a I_left(u, v) + b)| over the LiDAR points, with the disparity d of
/// each point's true depth for a baseline scaled by `scale`.
double photometricError(const Frame& f, const StereoRig& rig, double scale, double a, double b) {
  cv::Mat lf, rf, gl, gr;
  f.left.convertTo(lf, CV_32FC3);
  f.right.convertTo(rf, CV_32FC3);
  cv::cvtColor(lf, gl, cv::COLOR_BGR2GRAY);
  cv::cvtColor(rf, gr, cv::COLOR_BGR2GRAY);
  const double fb = rig.left.fx * rig.baseline() * scale;
  double sum = 0;
  int n = 0;
  for (const auto& p : f.scan) {
    const Eigen::Vector3d c = rig.T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
    if (c.z() < 3.0) continue;
    const double u = rig.left.fx * c.x() / c.z() + rig.left.cx;
    const double v = rig.left.fy * c.y() / c.z() + rig.left.cy;
    const double ur = u - fb / c.z();
    if (ur < 1 || u >= gl.cols - 2 || v < 1 || v >= gl.rows - 2) continue;
    sum += std::fabs(bilinear(gr, ur, v) - (a * bilinear(gl, u, v) + b));
    ++n;
  }
  return n > 0 ? sum / n : 1e9;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Every regular file under dir, by relative path, with its bytes.
std::map<std::string, std::string> readTree(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = readFile(e.path());
  return files;
}

/// Fraction of scan points higher than `height` m above the ground.
double fractionAbove(const LidarScan& scan, const Eigen::Isometry3d& T_world_lidar, double height) {
  int above = 0;
  for (const auto& p : scan)
    if ((T_world_lidar * Eigen::Vector3d(p.x, p.y, p.z)).z() > height) ++above;
  return double(above) / double(scan.size());
}

}  // namespace

TEST(Simulator, ParsesNamesAndRejectsBadOptions) {
  Scenario s;
  EXPECT_TRUE(sim::parseScenario("residential", &s));
  EXPECT_EQ(s, Scenario::kResidential);
  EXPECT_FALSE(sim::parseScenario("downtown", &s));
  NoiseLevel n;
  EXPECT_TRUE(parseNoiseLevel("high", &n));
  EXPECT_EQ(n, NoiseLevel::kHigh);
  EXPECT_FALSE(parseNoiseLevel("loud", &n));
  EXPECT_DOUBLE_EQ(SimNoise::forLevel(NoiseLevel::kNone).image_sigma, 0.0);
  EXPECT_DOUBLE_EQ(SimNoise::forLevel(NoiseLevel::kDefault).lidar_range_sigma_m, 0.02);
  SimOptions bad = options(Scenario::kUrban, 0);
  EXPECT_THROW(Simulator{bad}, DataError);
  bad = options(Scenario::kUrban, 1);
  bad.calib.Tr(0, 0) = 2.0;  // not a rotation
  EXPECT_THROW(Simulator{bad}, DataError);
  bad = options(Scenario::kUrban, 1);
  bad.calib.P[3] = bad.calib.P[2];  // no baseline
  EXPECT_THROW(Simulator{bad}, DataError);
  // A folder with foreign files is not overwritten.
  TempDir tmp;
  std::ofstream(tmp.path / "precious.txt") << "keep";
  EXPECT_THROW(simulateSequence(options(Scenario::kUrban, 1), tmp.str()), DataError);
  EXPECT_TRUE(fs::exists(tmp.path / "precious.txt"));
}

TEST(Simulator, DefaultRigIsKittiLike) {
  const Simulator sim(options(Scenario::kUrban, 1));
  const StereoRig& rig = sim.rig();
  EXPECT_DOUBLE_EQ(rig.left.fx, 718.856);
  EXPECT_EQ(rig.left.width, 1241);
  EXPECT_EQ(rig.left.height, 376);
  EXPECT_NEAR(rig.baseline(), 0.54, 1e-9);
  EXPECT_NEAR(rig.T_right_left.translation().x(), -0.54, 1e-9);
  // KITTI's 2011_09_30 Tr (velodyne -> rectified cam0): the LiDAR 0.334 m behind and 0.073 m
  // above cam0; the left colour camera (cam2) is 6 cm left of cam0, so in cam2's frame the
  // LiDAR is at x = -0.0048 + 0.06.
  EXPECT_LT(
      (rig.T_cam_lidar.translation() - Eigen::Vector3d(0.0552160, -0.0733743, -0.3339968)).norm(),
      1e-6);
  // LiDAR forward is the optical axis, LiDAR left is the camera's -x, LiDAR up its -y.
  EXPECT_GT(rig.T_cam_lidar.linear().col(0).z(), 0.9999);
  EXPECT_LT(rig.T_cam_lidar.linear().col(1).x(), -0.9999);
  EXPECT_LT(rig.T_cam_lidar.linear().col(2).y(), -0.9999);
  // The LiDAR sits 1.73 m above the ground.
  EXPECT_NEAR(sim.worldFromLidar(0).translation().z(), 1.73, 0.02);
}

TEST(Simulator, WritesKittiLayoutWithRingsPosesAndInfo) {
  TempDir tmp;
  const SimOptions o = options(Scenario::kUrban, 3);
  const Simulator sim(o);
  sim.writeSequence(tmp.str());
  const KittiSequence seq(tmp.str());
  ASSERT_EQ(seq.size(), 3u);
  EXPECT_EQ(seq.rig().left.width, 1241);
  EXPECT_EQ(seq.rig().left.height, 376);
  EXPECT_NEAR(seq.stamp(2) - seq.stamp(1), 0.1, 1e-9);
  EXPECT_LT(poseError(seq.rig().T_cam_lidar, sim.rig().T_cam_lidar).norm(), 1e-9);
  for (size_t i = 0; i < seq.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const Frame f = seq.load(i);
    EXPECT_EQ(f.left.type(), CV_8UC3);
    // The reader recovers exactly the generator's rings from the storage order.
    const LidarScan original = sim.renderScan(static_cast<int>(i));
    ASSERT_EQ(f.scan.size(), original.size());
    std::vector<int> per_ring(64, 0);
    int mismatched = 0;
    for (size_t k = 0; k < f.scan.size(); ++k) {
      mismatched += f.scan[k].ring != original[k].ring;
      ++per_ring[std::min<int>(f.scan[k].ring, 63)];
    }
    EXPECT_EQ(mismatched, 0);
    std::set<int> rings;
    for (const auto& p : f.scan) rings.insert(p.ring);
    EXPECT_EQ(rings.size(), 64u);
    EXPECT_LE(*std::max_element(per_ring.begin(), per_ring.end()), 2000);
    EXPECT_GT(per_ring[0], 1900);  // the lowest beam always sees the ground
    EXPECT_GT(f.scan.size(), 70000u);
    EXPECT_LT(f.scan.size(), 128001u);
    double max_range = 0, mean_i = 0, var_i = 0;
    for (const auto& p : f.scan) {
      max_range = std::max(max_range, std::sqrt(double(p.x) * p.x + p.y * p.y + p.z * p.z));
      mean_i += p.intensity;
      EXPECT_GE(p.intensity, 0.f);
      EXPECT_LE(p.intensity, 1.f);
    }
    mean_i /= f.scan.size();
    for (const auto& p : f.scan) var_i += (p.intensity - mean_i) * (p.intensity - mean_i);
    EXPECT_LE(max_range, 120.0);
    EXPECT_GT(std::sqrt(var_i / f.scan.size()), 0.05) << "intensity should vary with material";
  }
  // poses.txt: cam0 poses, identity first, moving forward (+z of cam0) at 8-14 m/s.
  std::ifstream poses(tmp.path / "poses.txt");
  std::vector<Eigen::Vector3d> positions;
  std::string line;
  while (std::getline(poses, line)) {
    std::istringstream in(line);
    std::vector<double> v{std::istream_iterator<double>(in), std::istream_iterator<double>()};
    ASSERT_EQ(v.size(), 12u);
    positions.emplace_back(v[3], v[7], v[11]);
    if (positions.size() == 1) {
      EXPECT_NEAR(v[0], 1.0, 1e-9);
      EXPECT_NEAR(v[5], 1.0, 1e-9);
      EXPECT_NEAR(v[10], 1.0, 1e-9);
    }
  }
  ASSERT_EQ(positions.size(), 3u);
  const Eigen::Vector3d step = positions[1] - positions[0];
  EXPECT_GT(step.z(), 0.8);
  EXPECT_LT(step.norm(), 1.4);
  EXPECT_LT(std::fabs(step.x()), 0.1);
  EXPECT_LT((sim.cam0Pose(2).translation() - positions[2]).norm(), 1e-9);
  const auto info = readSimInfo(tmp.path.string());
  EXPECT_EQ(info.at("scenario"), "urban");
  EXPECT_EQ(info.at("seed"), "7");
  EXPECT_NEAR(std::stod(info.at("brightness_a")), o.right_gain / o.left_gain, 1e-9);
  EXPECT_NEAR(std::stod(info.at("brightness_b")), o.right_offset, 1e-9);
}

TEST(Simulator, RandomRigIsDrawnFromTheSeedWithinRealRanges) {
  std::set<int> conventions;
  for (uint64_t seed = 1; seed <= 60; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    SimOptions o = options(Scenario::kUrban, 1, seed);
    useRandomRig(seed, &o);
    const StereoRig rig = rigFromOdometryCalib(o.calib);
    EXPECT_EQ(o.rig_source, "random");
    EXPECT_GE(o.width, 640);
    EXPECT_LE(o.width, 1400);
    EXPECT_GE(o.height, 240);
    EXPECT_LE(o.height, 600);
    EXPECT_GE(rig.left.fx, 400.0);
    EXPECT_LE(rig.left.fx, 1100.0);
    EXPECT_NEAR(rig.left.cx, 0.5 * o.width, 0.031 * o.width);
    EXPECT_NEAR(rig.left.cy, 0.5 * o.height, 0.051 * o.height);
    // The right camera a baseline to the right and a few mm off the left camera's x axis.
    const Eigen::Vector3d t = rig.T_right_left.translation();
    EXPECT_GE(-t.x(), 0.12);
    EXPECT_LE(-t.x(), 0.6);
    for (double off : {t.y(), t.z()}) {
      EXPECT_GE(std::fabs(off), 0.0005);
      EXPECT_LE(std::fabs(off), 0.004);
    }
    // The LiDAR within 1 m of the left camera, upright within a few degrees.
    const Eigen::Isometry3d T_lidar_cam = rig.T_cam_lidar.inverse();
    EXPECT_LE(T_lidar_cam.translation().norm(), 1.12);  // plus the left camera's offset
    const Eigen::Vector3d lidar_up = o.T_vehicle_lidar.linear().col(2);
    EXPECT_GT(lidar_up.z(), std::cos(4.5 / kDegPerRad));
    EXPECT_GE(o.T_vehicle_lidar.translation().z() + 1.73, 1.2);
    const Eigen::Vector3d lidar_x = o.T_vehicle_lidar.linear().col(0);
    conventions.insert(
        static_cast<int>(std::lround(std::atan2(lidar_x.y(), lidar_x.x()) / (M_PI / 2))) & 3);
    // The same seed, the same rig.
    SimOptions again = options(Scenario::kUrban, 1, seed);
    useRandomRig(seed, &again);
    EXPECT_EQ(again.calib.Tr, o.calib.Tr);
    EXPECT_EQ(again.calib.P[3], o.calib.P[3]);
  }
  EXPECT_EQ(conventions.size(), 4u) << "every axis convention drawn in 60 rigs";
}

TEST(Simulator, RandomRigIsWhatTheImagesAndTheScanShow) {
  // A rig unlike the default one: the LiDAR where the seed puts it, the right camera a few mm
  // off the x axis. The generator must render it as calib.txt says.
  SimOptions o = options(Scenario::kUrban, 1, 104);
  useRandomRig(o.seed, &o);
  const Simulator sim(o);
  const StereoRig& rig = sim.rig();
  ASSERT_FALSE(isRectified(rig.T_right_left));
  const Frame f = sim.renderFrame(0);
  ASSERT_EQ(f.left.cols, o.width);
  ASSERT_EQ(f.left.rows, o.height);
  const StereoCloud cloud = computeStereoCloud(f.left, f.right, rig, rig.T_right_left);
  const DisparityResidual res = lidarDisparityResidual(f.scan, cloud, rig.T_cam_lidar);
  const VerticalAlignment rows = verticalAlignment(f.left, f.right, cloud, rig, rig.T_right_left);
  std::cout << "[ random   ] " << o.width << "x" << o.height << ", baseline " << rig.baseline()
            << " m: disparity residual median " << res.median_px << " px of " << res.points
            << " points; rows median " << rows.median_px << " px of " << rows.points << "\n";
  EXPECT_GT(res.points, 3000);
  EXPECT_LT(std::fabs(res.median_px), 0.15);
  EXPECT_GT(rows.points, 300);
  EXPECT_LT(std::fabs(rows.median_px), 0.05);
  // The LiDAR still sits where the trajectory's vehicle frame puts it.
  EXPECT_LT((sim.worldFromLidar(0).translation() -
             (sim.worldFromVehicleAt(0.0) * o.T_vehicle_lidar).translation())
                .norm(),
            1e-12);
}

TEST(Simulator, OffAxisPairSeesWhatTheLeftCameraSees) {
  // A real rectified pair's right camera sits a few mm off the left camera's x axis (KITTI's
  // P3: 2-3 mm), so its rows fall a fraction of a pixel apart from the left camera's on the
  // scene. Each pixel must integrate its area for the two images to show the same surface: with
  // one sample per pixel the SGBM disparity of this frame is 0.06-0.07 px further off the LiDAR's
  // than on the axis, of opposite sign for a right camera 3.3 mm above or below it.
  const auto residual = [](double dy) {
    SimOptions o = options(Scenario::kUrban, 1, 11);
    o.noise = NoiseLevel::kNone;
    o.calib.P[3].col(3) += o.calib.P[3].leftCols<3>() * Eigen::Vector3d(0, dy, 0);
    const Simulator sim(o);
    const Frame f = sim.renderFrame(0);
    const StereoCloud cloud =
        computeStereoCloud(f.left, f.right, sim.rig(), sim.rig().T_right_left);
    return lidarDisparityResidual(f.scan, cloud, sim.rig().T_cam_lidar);
  };
  // P = K [I | t]: a camera centre 3.3 mm further along y (down) is t_y 3.3 mm lower.
  const DisparityResidual on_axis = residual(0.0), below = residual(-0.0033),
                          above = residual(0.0033);
  std::cout << "[ off-axis ] SGBM - LiDAR disparity, median: on the axis " << on_axis.median_px
            << " px, 3.3 mm above " << above.median_px << " px, 3.3 mm below " << below.median_px
            << " px\n";
  EXPECT_GT(above.points, 5000);
  EXPECT_GT(below.points, 5000);
  EXPECT_LT(std::fabs(on_axis.median_px), 0.03);
  EXPECT_LT(std::fabs(above.median_px - on_axis.median_px), 0.025);
  EXPECT_LT(std::fabs(below.median_px - on_axis.median_px), 0.025);
}

TEST(Simulator, GroundTruthAgreesWithSgbmAndPhotometry) {
  const SimOptions o = options(Scenario::kUrban, 21);
  const Simulator sim(o);
  for (int i : {0, 20}) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const Frame f = sim.renderFrame(i);
    const cv::Mat disp = sgbmDisparity(f.left, f.right);
    const DisparityComparison c = compareWithLidar(f.scan, disp, sim.rig(), sim.rig().T_cam_lidar);
    std::cout << "[ sgbm     ] frame " << i << ": " << c.valid << " of " << c.projected
              << " LiDAR pixels have an SGBM disparity, median |diff| " << c.median_abs_diff
              << " px\n";
    EXPECT_GT(c.projected, 12000);
    EXPECT_GT(c.valid, 0.8 * c.projected) << "SGBM disparity should be dense";
    EXPECT_LT(c.median_abs_diff, 0.5);
    // Photometric error along the true disparity, with the known brightness affine: minimal at
    // the true baseline, and the affine explains the left/right brightness difference.
    const double a = o.right_gain / o.left_gain, b = o.right_offset - a * o.left_offset;
    std::map<double, double> err;
    for (double s : {0.9, 0.97, 1.0, 1.03, 1.1}) err[s] = photometricError(f, sim.rig(), s, a, b);
    std::cout << "[ photo    ] mean |I_r - (a I_l + b)| at baseline x0.9 " << err[0.9] << ", x0.97 "
              << err[0.97] << ", x1 " << err[1.0] << ", x1.03 " << err[1.03] << ", x1.1 "
              << err[1.1] << "\n";
    for (double s : {0.9, 0.97, 1.03, 1.1}) EXPECT_LT(err[1.0], err[s]) << "scale " << s;
    EXPECT_LT(err[1.0], 0.6 * err[0.9]);
    EXPECT_LT(err[1.0], 0.6 * err[1.1]);
    EXPECT_LT(err[1.0], 0.7 * photometricError(f, sim.rig(), 1.0, 1.0, 0.0));
  }
}

TEST(Simulator, DepthRenderIsTheGeometryTheCameraAndTheLidarSee) {
  // sim::renderCameraDepth: the exact depth of every pixel centre, the ground truth of a stereo
  // matcher. On the road it is the road plane's depth; where the noise-free LiDAR hits a surface
  // away from depth edges, it is that point's depth; above the horizon's buildings it is NaN.
  SimOptions o = options(Scenario::kUrban, 21);
  o.noise = NoiseLevel::kNone;
  const Simulator sim(o);
  const StereoRig& rig = sim.rig();
  const Eigen::Isometry3d T_world_cam = sim.worldFromLidar(0) * rig.T_cam_lidar.inverse();
  const cv::Mat depth = sim::renderCameraDepth(sim.world(), rig.left, T_world_cam, 250.f, 2);
  ASSERT_EQ(depth.type(), CV_32F);
  ASSERT_EQ(depth.size(), cv::Size(rig.left.width, rig.left.height));
  // Road: the plane z = 0 of the world.
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  const Eigen::Vector3d n = T_cam_world.linear() * Eigen::Vector3d::UnitZ();
  const double h = n.dot(T_cam_world.translation());
  int road = 0, on_plane = 0;
  for (int v = rig.left.height - 40; v < rig.left.height; ++v)
    for (int u = rig.left.width / 2 - 100; u < rig.left.width / 2 + 100; ++u) {
      const Eigen::Vector3d ray((u - rig.left.cx) / rig.left.fx, (v - rig.left.cy) / rig.left.fy,
                                1.0);
      const double Z = h / n.dot(ray);
      ++road;
      if (std::fabs(depth.at<float>(v, u) - Z) < 1e-4 * Z) ++on_plane;
    }
  EXPECT_GT(on_plane, 0.95 * road) << "the road in front of the car";
  // LiDAR points (noise-free) at pixels whose 3x3 neighbourhood is one smooth surface.
  std::vector<double> diff;
  const LidarScan scan = sim.renderScan(0);
  for (const LidarPoint& p : scan) {
    const Eigen::Vector3d X = rig.T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
    if (X.z() < 2.0 || X.z() > 40.0) continue;
    const double u = rig.left.fx * X.x() / X.z() + rig.left.cx;
    const double v = rig.left.fy * X.y() / X.z() + rig.left.cy;
    const int iu = static_cast<int>(std::floor(u)), iv = static_cast<int>(std::floor(v));
    if (iu < 1 || iv < 1 || iu + 2 >= depth.cols || iv + 2 >= depth.rows) continue;
    float lo = 1e9f, hi = 0.f;
    for (int dv = -1; dv <= 2; ++dv)
      for (int du = -1; du <= 2; ++du) {
        const float z = depth.at<float>(iv + dv, iu + du);
        lo = std::min(lo, std::isfinite(z) ? z : 0.f),
        hi = std::max(hi, std::isfinite(z) ? z : 1e9f);
      }
    if (!(hi - lo < 0.02f * lo)) continue;
    // Inverse depth is affine in the image on a plane: interpolate it.
    const double fu = u - iu, fv = v - iv;
    const double inv =
        (1 - fv) * ((1 - fu) / depth.at<float>(iv, iu) + fu / depth.at<float>(iv, iu + 1)) +
        fv * ((1 - fu) / depth.at<float>(iv + 1, iu) + fu / depth.at<float>(iv + 1, iu + 1));
    diff.push_back(std::fabs(1.0 / inv - X.z()));
  }
  ASSERT_GT(diff.size(), 5000u);
  std::nth_element(diff.begin(), diff.begin() + diff.size() / 2, diff.end());
  const double median = diff[diff.size() / 2];
  std::nth_element(diff.begin(), diff.begin() + diff.size() * 9 / 10, diff.end());
  std::cout << "[ depth    ] " << diff.size()
            << " LiDAR points on smooth surfaces: |render - LiDAR|"
            << " median " << median * 1000 << " mm, 90 % " << diff[diff.size() * 9 / 10] * 1000
            << " mm\n";
  EXPECT_LT(median, 0.002);
  // The sky.
  int sky = 0;
  for (int u = 0; u < depth.cols; ++u) sky += std::isnan(depth.at<float>(0, u)) ? 1 : 0;
  EXPECT_GT(sky, 0) << "no pixel of the top row sees the sky";
}

TEST(Simulator, LidarNoiseFollowsTheNoiseLevel) {
  // Height above the road of the points that hit it: exactly 0 without noise; with noise it
  // spreads by about sigma_d * sin(elevation) plus range * sigma_l.
  std::map<NoiseLevel, double> spread;
  for (NoiseLevel level : {NoiseLevel::kNone, NoiseLevel::kDefault, NoiseLevel::kHigh}) {
    SimOptions o = options(Scenario::kHighway, 1);
    o.noise = level;
    const Simulator sim(o);
    const LidarScan scan = sim.renderScan(0);
    const Eigen::Isometry3d T = sim.worldFromLidar(0);
    std::vector<double> heights;
    for (const auto& p : scan) {
      const double z = (T * Eigen::Vector3d(p.x, p.y, p.z)).z();
      if (std::fabs(z) < 0.2 && std::hypot(p.x, p.y) < 12.0) heights.push_back(std::fabs(z));
    }
    ASSERT_GT(heights.size(), 10000u);
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
    spread[level] = heights[heights.size() / 2];
  }
  std::cout << "[ noise    ] median |height| of road points: none " << spread[NoiseLevel::kNone]
            << " m, default " << spread[NoiseLevel::kDefault] << " m, high "
            << spread[NoiseLevel::kHigh] << " m\n";
  EXPECT_LT(spread[NoiseLevel::kNone], 1e-4);  // exact geometry without noise
  EXPECT_GT(spread[NoiseLevel::kDefault], 0.002);
  EXPECT_LT(spread[NoiseLevel::kDefault], 0.015);
  EXPECT_GT(spread[NoiseLevel::kHigh], 2.0 * spread[NoiseLevel::kDefault]);
}

TEST(Simulator, SameSeedSameBytesAnyThreadCount) {
  TempDir a, b, c;
  SimOptions o = options(Scenario::kResidential, 2, 11);
  o.threads = 1;
  simulateSequence(o, a.str());
  o.threads = 2;
  simulateSequence(o, b.str());
  const auto fa = readTree(a.str()), fb = readTree(b.str());
  ASSERT_EQ(fa.size(), 10u);  // calib, times, poses, sim_info, 2 x (2 images + 1 scan)
  for (const auto& [name, bytes] : fa) {
    ASSERT_TRUE(fb.count(name)) << name;
    EXPECT_TRUE(bytes == fb.at(name)) << name << " differs between two runs";
  }
  // Rewriting into an earlier output replaces it; another seed gives other data.
  o.seed = 12;
  simulateSequence(o, b.str());
  const auto fc = readTree(b.str());
  EXPECT_EQ(fc.size(), fa.size());
  EXPECT_NE(fc.at("image_2/000000.png"), fa.at("image_2/000000.png"));
  EXPECT_NE(fc.at("velodyne/000001.bin"), fa.at("velodyne/000001.bin"));
  EXPECT_EQ(fc.at("calib.txt"), fa.at("calib.txt"));
  // Rows and rings rendered on several threads give the same frame as on one.
  const Simulator sim(o);
  const Frame one = sim.renderFrame(1, 1), two = sim.renderFrame(1, 2);
  EXPECT_EQ(cv::norm(one.left, two.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(one.right, two.right, cv::NORM_INF), 0.0);
  ASSERT_EQ(one.scan.size(), two.scan.size());
  int differing = 0;
  for (size_t k = 0; k < one.scan.size(); ++k) {
    const LidarPoint &p = one.scan[k], &q = two.scan[k];
    differing +=
        p.x != q.x || p.y != q.y || p.z != q.z || p.intensity != q.intensity || p.ring != q.ring;
  }
  EXPECT_EQ(differing, 0);
}

TEST(Simulator, EveryKthFrameIsTheSameDriveAtAKeyframeRate) {
  TempDir all, every;
  SimOptions o = options(Scenario::kUrban, 7, 13);
  o.width = 320;
  o.height = 120;
  simulateSequence(o, all.str());
  o.write_every = 3;  // frames 0, 3, 6 of the same drive
  simulateSequence(o, every.str());
  const auto a = readTree(all.str()), e = readTree(every.str());
  ASSERT_EQ(e.size(), 4u + 3u * 3u);
  for (int k = 0; k < 3; ++k) {
    char from[16], to[16];
    std::snprintf(from, sizeof from, "%06d", 3 * k);
    std::snprintf(to, sizeof to, "%06d", k);
    for (const char* f : {"image_2/%s.png", "image_3/%s.png", "velodyne/%s.bin"}) {
      char pa[40], pe[40];
      std::snprintf(pa, sizeof pa, f, from);
      std::snprintf(pe, sizeof pe, f, to);
      EXPECT_EQ(e.at(pe), a.at(pa)) << pe << " is not " << pa;
    }
  }
  auto lines = [](const std::string& text, int step) {
    std::istringstream in(text);
    std::string line, kept;
    for (int i = 0; std::getline(in, line); ++i)
      if (i % step == 0) kept += line + "\n";
    return kept;
  };
  EXPECT_EQ(e.at("times.txt"), lines(a.at("times.txt"), 3));
  EXPECT_EQ(e.at("poses.txt"), lines(a.at("poses.txt"), 3));
  EXPECT_EQ(readSimInfo(every.str()).at("written_every"), "3");
  o.write_every = 8;
  EXPECT_THROW(simulateSequence(o, every.str()), DataError);
}

TEST(Simulator, CalibFileBecomesTheGroundTruth) {
  // A rig whose camera is rotated by about 2.3 deg and shifted by 17 cm relative to the default.
  KittiOdometryCalib calib = defaultSimCalib();
  const Eigen::Matrix3d R = tescalib::expSO3(Eigen::Vector3d(1.5, -1.0, 1.5) / kDegPerRad);
  calib.Tr.leftCols<3>() = R * calib.Tr.leftCols<3>();
  calib.Tr.col(3) += Eigen::Vector3d(0.1, -0.05, 0.12);
  TempDir tmp;
  const std::string calib_path = (tmp.path / "my_calib.txt").string();
  writeKittiOdometryCalib(calib_path, calib);
  SimOptions o = options(Scenario::kUrban, 1, 5);
  o.calib = readKittiOdometryCalib(calib_path);
  simulateSequence(o, (tmp.path / "seq").string());
  const KittiSequence seq((tmp.path / "seq").string());
  const StereoRig expected = rigFromOdometryCalib(calib);
  EXPECT_LT(poseError(seq.rig().T_cam_lidar, expected.T_cam_lidar).norm(), 1e-6);
  const Frame f = seq.load(0);
  const cv::Mat disp = sgbmDisparity(f.left, f.right);
  const DisparityComparison right_gt =
      compareWithLidar(f.scan, disp, seq.rig(), seq.rig().T_cam_lidar);
  const Eigen::Isometry3d old_T = Simulator(options(Scenario::kUrban, 1)).rig().T_cam_lidar;
  const DisparityComparison old_gt = compareWithLidar(f.scan, disp, seq.rig(), old_T);
  std::cout << "[ calib    ] median |SGBM - LiDAR disparity|: given calib "
            << right_gt.median_abs_diff << " px, default calib " << old_gt.median_abs_diff
            << " px\n";
  EXPECT_LT(right_gt.median_abs_diff, 0.5);
  EXPECT_GT(old_gt.median_abs_diff, 1.0);
  const DisparityAgreement agree =
      lidarDisparityAgreement(f.scan, f.left, f.right, seq.rig(), seq.rig().T_cam_lidar);
  EXPECT_EQ(agree.best_global_shift, 0);
  EXPECT_GT(agree.fraction_within_1px, 0.8);
}

// At the generator's calibration the stereo cloud's disparity agrees with the LiDAR's at every
// depth (within SGBM's 0.12 px on the steep near road); with the right image moved 0.3 px to the
// right, every depth shows 0.3 px less: a depth-independent offset, as KITTI's pairs show.
TEST(Consistency, DisparityResidualShowsADisparityOffsetAtEveryDepth) {
  const Simulator sim(options(Scenario::kUrban, 1));
  const StereoRig rig = sim.rig();
  const Frame f = sim.renderFrame(0);
  const auto residual = [&](double shift_px) {
    cv::Mat right;
    const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, shift_px, 0, 1, 0);
    cv::warpAffine(f.right, right, M, f.right.size(), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
    const StereoCloud cloud = computeStereoCloud(f.left, right, rig, rig.T_right_left);
    const DisparityResidual r = lidarDisparityResidual(f.scan, cloud, rig.T_cam_lidar);
    std::cout << "[ disp     ] right image " << shift_px << " px: " << r.points
              << " points, median " << r.median_px << " px, by depth";
    for (int b = 0; b < DisparityResidual::kBins; ++b)
      std::cout << " " << r.bin_median_px[b] << " (" << r.bin_points[b] << ")";
    std::cout << "\n";
    return r;
  };
  const DisparityResidual exact = residual(0.0), shifted = residual(0.3);
  EXPECT_GT(exact.points, 5000);
  EXPECT_LT(std::fabs(exact.median_px), 0.05);
  EXPECT_NEAR(shifted.median_px - exact.median_px, -0.3, 0.05);
  for (int b = 0; b < DisparityResidual::kBins; ++b) {
    ASSERT_GT(exact.bin_points[b], 300) << "bin " << b;
    EXPECT_LT(std::fabs(exact.bin_median_px[b]), 0.15) << "bin " << b;
    EXPECT_NEAR(shifted.bin_median_px[b] - exact.bin_median_px[b], -0.3, 0.07) << "bin " << b;
  }
}

// The rows of a generated (exactly rectified) pair agree with its calibration; moving the right
// image down by 0.4 px, or turning it 0.05 deg about its principal point, is measured as such.
TEST(Consistency, VerticalAlignmentMeasuresWhatTheCalibrationDoesNotExplain) {
  const Simulator sim(options(Scenario::kUrban, 1));
  const StereoRig rig = sim.rig();
  const Frame f = sim.renderFrame(0);
  const StereoCloud cloud = computeStereoCloud(f.left, f.right, rig, rig.T_right_left);
  const auto measure = [&](const cv::Mat& M) {
    cv::Mat right;
    cv::warpAffine(f.right, right, M, f.right.size(), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
    return verticalAlignment(f.left, right, cloud, rig, rig.T_right_left);
  };
  const VerticalAlignment exact = measure(cv::Mat::eye(2, 3, CV_64F));
  const VerticalAlignment down = measure((cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, 0.4));
  const double a = 0.05 / kDegPerRad, c = std::cos(a), s = std::sin(a);
  const double cx = rig.right.cx, cy = rig.right.cy;
  const VerticalAlignment rolled =
      measure((cv::Mat_<double>(2, 3) << c, -s, cx - c * cx + s * cy, s, c, cy - s * cx - c * cy));
  for (const auto* v : {&exact, &down, &rolled})
    std::cout << "[ rows     ] " << v->points << " corners, median " << v->median_px << " px, fit "
              << v->offset_px << " + " << v->slope_x_px << " x + " << v->slope_y_px << " y, spread "
              << v->spread_px << "\n";
  EXPECT_GT(exact.points, 500);
  EXPECT_LT(std::fabs(exact.median_px), 0.05);
  EXPECT_LT(std::fabs(exact.slope_x_px), 0.1);
  EXPECT_NEAR(down.median_px, 0.4, 0.06);
  EXPECT_NEAR(down.offset_px, 0.4, 0.06);
  EXPECT_LT(std::fabs(down.slope_x_px), 0.1);
  // dv = a (u - cx) = a fx x: a slope of 0.63 px per unit of x.
  EXPECT_NEAR(rolled.slope_x_px, a * rig.right.fx, 0.15 * a * rig.right.fx);
  EXPECT_LT(std::fabs(rolled.offset_px), 0.06);
}

TEST(Simulator, HighwayHasHardlyAnyVerticalStructure) {
  std::map<Scenario, double> above;
  for (Scenario s : {Scenario::kUrban, Scenario::kResidential, Scenario::kHighway}) {
    const Simulator sim(options(s, 31, 3));
    double sum = 0;
    for (int i : {0, 15, 30}) sum += fractionAbove(sim.renderScan(i), sim.worldFromLidar(i), 1.5);
    above[s] = sum / 3;
  }
  std::cout << "[ scenario ] LiDAR points more than 1.5 m above the ground: urban "
            << above[Scenario::kUrban] << ", residential " << above[Scenario::kResidential]
            << ", highway " << above[Scenario::kHighway] << "\n";
  EXPECT_GT(above[Scenario::kUrban], 0.1);
  EXPECT_GT(above[Scenario::kResidential], 0.05);
  EXPECT_LT(above[Scenario::kHighway], 0.01);
  EXPECT_LT(above[Scenario::kHighway], 0.1 * above[Scenario::kResidential]);
  EXPECT_LT(above[Scenario::kHighway], 0.1 * above[Scenario::kUrban]);
}

TEST(Simulator, VehicleDrivesAtCitySpeedsOnGentleCurves) {
  const Simulator sim(options(Scenario::kUrban, 600, 9));
  double max_yaw_rate = 0;
  for (int i = 1; i < 600; ++i) {
    const Eigen::Isometry3d a = sim.worldFromLidar(i - 1), b = sim.worldFromLidar(i);
    const double v = (b.translation() - a.translation()).norm() / 0.1;
    EXPECT_GE(v, 7.9);
    EXPECT_LE(v, 14.1);
    max_yaw_rate = std::max(max_yaw_rate, logSO3(a.linear().transpose() * b.linear()).norm() / 0.1);
  }
  EXPECT_LT(max_yaw_rate * kDegPerRad, 6.0);  // deg/s: radii of hundreds of metres
}

TEST(Simulator, SweptScanIsReportedInTheFrameOfEachBeamsFiring) {
  // --lidar-sweep: a beam at azimuth az fires at sweepTime(az) from the stamp and is reported in
  // the sensor frame of that moment. Brought to the world with the frame's pose (as if the scan
  // were instantaneous) the points are up to v x 50 ms off; de-skewed with the trajectory's
  // velocity at the stamp they land where they were measured, to the constant-velocity model's
  // accuracy over 50 ms.
  SimOptions o = options(Scenario::kUrban, 3);
  o.noise = NoiseLevel::kNone;
  o.lidar_sweep = true;
  const Simulator sim(o);
  const int i = 1;
  const LidarScan scan = sim.renderScan(i);
  ASSERT_GT(scan.size(), 50000u);
  const Eigen::Isometry3d T0 = sim.worldFromLidar(i);
  const double h = 1e-4;
  const Eigen::Isometry3d dT = T0.inverse() * sim.worldFromLidarAt(sim.stamp(i) + h);
  ScanMotion m;
  m.velocity = dT.translation() / h;
  m.angular_velocity = logSO3(dT.linear()) / h;
  m.valid = true;
  LidarScan fixed = scan;
  deskewScan(&fixed, m);
  double raw_max = 0, fixed_max = 0, front_max = 0;
  for (size_t k = 0; k < scan.size(); ++k) {
    const Eigen::Vector3d p(scan[k].x, scan[k].y, scan[k].z);
    const double az = std::atan2(p.y(), p.x());
    const Eigen::Vector3d truth = sim.worldFromLidarAt(sim.stamp(i) + sweepTime(az)) * p;
    const double raw = (T0 * p - truth).norm();
    raw_max = std::max(raw_max, raw);
    if (std::fabs(az) < 0.5 * M_PI / 180) front_max = std::max(front_max, raw);
    const Eigen::Vector3d q(fixed[k].x, fixed[k].y, fixed[k].z);
    fixed_max = std::max(fixed_max, (T0 * q - truth).norm());
  }
  std::cout << "[ sweep    ] speed " << m.velocity.norm() << " m/s; world error of the raw scan "
            << raw_max << " m (within 0.5 deg of forward " << front_max << " m), de-skewed "
            << fixed_max << " m\n";
  EXPECT_GT(raw_max, 0.5 * 0.05 * m.velocity.norm());
  EXPECT_LT(front_max, 0.01);
  EXPECT_LT(fixed_max, 0.01);
}

TEST(Simulator, AnExtrinsicStepMovesTheLidarOrTheRightCameraFromItsTime) {
  TempDir plain, lidar, stereo;
  SimOptions o = options(Scenario::kUrban, 2, 11);
  o.width = 400;
  o.height = 150;
  simulateSequence(o, plain.str());
  o.step.at_s = 0.1;  // frame 1
  o.step.rot_deg = 0.5;
  o.step.trans_m = 0.03;
  simulateSequence(o, lidar.str());
  o.step.stereo = true;
  simulateSequence(o, stereo.str());
  const auto p = readTree(plain.str()), l = readTree(lidar.str()), s = readTree(stereo.str());
  EXPECT_EQ(p.count("calib_after_step.txt"), 0u);
  for (const auto* stepped : {&l, &s}) {
    ASSERT_EQ(stepped->size(), p.size() + 1);
    for (const char* same : {"calib.txt", "times.txt", "poses.txt", "image_2/000000.png",
                             "image_3/000000.png", "velodyne/000000.bin", "image_2/000001.png"})
      EXPECT_EQ(stepped->at(same), p.at(same)) << same;  // before the step, and the left camera
  }
  // A LiDAR step moves the LiDAR (the cameras stay), a stereo step the right camera.
  EXPECT_NE(l.at("velodyne/000001.bin"), p.at("velodyne/000001.bin"));
  EXPECT_EQ(l.at("image_3/000001.png"), p.at("image_3/000001.png"));
  EXPECT_EQ(s.at("velodyne/000001.bin"), p.at("velodyne/000001.bin"));
  EXPECT_NE(s.at("image_3/000001.png"), p.at("image_3/000001.png"));
  // calib_after_step.txt: the truth moved by exactly the step.
  const StereoRig before = rigFromOdometryCalib(readKittiOdometryCalib(plain.str() + "/calib.txt"));
  const StereoRig after_l =
      rigFromOdometryCalib(readKittiOdometryCalib(lidar.str() + "/calib_after_step.txt"));
  const StereoRig after_s =
      rigFromOdometryCalib(readKittiOdometryCalib(stereo.str() + "/calib_after_step.txt"));
  const Vector6d dl = poseError(after_l.T_cam_lidar, before.T_cam_lidar);
  EXPECT_NEAR(dl.head<3>().norm() * kDegPerRad, 0.5, 1e-6);
  EXPECT_NEAR(dl.tail<3>().norm(), 0.03, 1e-6);
  EXPECT_LT(poseError(after_l.T_right_left, before.T_right_left).norm(), 1e-9);
  const Vector6d ds = poseError(after_s.T_right_left, before.T_right_left);
  EXPECT_NEAR(ds.head<3>().norm() * kDegPerRad, 0.5, 1e-6);
  EXPECT_NEAR(ds.tail<3>().norm(), 0.03, 1e-6);
  EXPECT_LT(poseError(after_s.T_cam_lidar, before.T_cam_lidar).norm(), 1e-6);
  const auto info = readSimInfo(lidar.str());
  EXPECT_EQ(info.at("extrinsic_step_at_s"), "0.1");
  EXPECT_EQ(info.at("extrinsic_step"), "lidar");
  // The stepped LiDAR sits where the new truth puts it from the camera, which did not move.
  o.step.stereo = false;
  const Simulator stepped(o);
  o.step.at_s = -1;
  const Simulator unstepped(o);
  const Eigen::Isometry3d cam = unstepped.worldFromLidar(1) * before.T_cam_lidar.inverse();
  EXPECT_LT(poseError(stepped.worldFromLidar(1), cam * after_l.T_cam_lidar).norm(), 1e-6);
  EXPECT_LT(poseError(stepped.worldFromLidar(0), unstepped.worldFromLidar(0)).norm(), 1e-12);
}
