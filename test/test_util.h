// Helpers shared by the tests: temporary folders and tiny synthetic KITTI sequences.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/kitti_reader.h"

namespace tescalib_test {

namespace fs = std::filesystem;

inline std::string kittiDir() { return TESCALIB_KITTI_DIR; }
inline bool haveKitti() { return fs::is_directory(kittiDir() + "/sequences/00"); }
#define SKIP_WITHOUT_KITTI()                                                \
  if (!tescalib_test::haveKitti())                                          \
  GTEST_SKIP() << "KITTI frames not found at " << tescalib_test::kittiDir() \
               << " (../shared/data/kitti_odometry_mini); skipping the real-data test"

/// A fresh temporary folder removed at destruction.
struct TempDir {
  fs::path path;
  TempDir() {
    static int counter = 0;
    path = fs::temp_directory_path() /
           ("tescalib_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string str() const { return path.string(); }
};

/// A scan in KITTI's storage order: 64 rings, top beam first, each one revolution starting and
/// ending facing forward.
inline tescalib::LidarScan syntheticScan(int rings = 64, int per_ring = 400, double range = 10) {
  tescalib::LidarScan scan;
  for (int r = rings - 1; r >= 0; --r) {
    const double elev = (-24.9 + (26.9 * r) / (rings - 1)) / tescalib::kDegPerRad;
    for (int k = 0; k < per_ring; ++k) {
      const double az = 2 * M_PI * (k + 0.5) / per_ring;  // counter-clockwise from the front
      tescalib::LidarPoint p;
      p.x = float(range * std::cos(elev) * std::cos(az));
      p.y = float(range * std::cos(elev) * std::sin(az));
      p.z = float(range * std::sin(elev));
      p.intensity = float(k % 7) / 7.f;
      scan.push_back(p);
    }
  }
  return scan;
}

inline tescalib::KittiOdometryCalib syntheticCalib() {
  tescalib::KittiOdometryCalib c;
  Eigen::Matrix<double, 3, 4> P;
  P << 700, 0, 320, 0, 0, 700, 120, 0, 0, 0, 1, 0;
  c.P[0] = c.P[1] = c.P[2] = c.P[3] = P;
  c.P[1](0, 3) = -700 * 0.54;
  c.P[2](0, 3) = 700 * 0.06;
  c.P[3](0, 3) = 700 * (0.06 - 0.54);
  c.Tr << 0, -1, 0, 0.02, 0, 0, -1, -0.08, 1, 0, 0, -0.27;
  return c;
}

/// Writes a tiny odometry-layout sequence with `frames` frames of 640x240 random images (left and
/// right each their own).
inline void writeSyntheticSequence(const std::string& dir, int frames, int width = 640,
                                   int height = 240) {
  fs::create_directories(dir + "/image_2");
  fs::create_directories(dir + "/image_3");
  fs::create_directories(dir + "/velodyne");
  tescalib::writeKittiOdometryCalib(dir + "/calib.txt", syntheticCalib());
  std::ofstream times(dir + "/times.txt");
  cv::RNG rng(3);
  for (int i = 0; i < frames; ++i) {
    times << 0.1 * i << "\n";
    char name[32];
    std::snprintf(name, sizeof(name), "%06d", i);
    cv::Mat img(height, width, CV_8UC3);
    rng.fill(img, cv::RNG::UNIFORM, 0, 255);
    cv::imwrite(dir + "/image_2/" + name + ".png", img);
    rng.fill(img, cv::RNG::UNIFORM, 0, 255);  // a right image of its own: a swap shows
    cv::imwrite(dir + "/image_3/" + name + ".png", img);
    tescalib::writeVelodyneBin(dir + "/velodyne/" + name + ".bin", syntheticScan());
  }
}

/// Writes a tiny KITTI raw drive `parent/name` (image_02/03 data, velodyne_points, 640x240, the
/// synthetic calibration as calib_cam_to_cam.txt and calib_velo_to_cam.txt in `parent`) with one
/// frame per line of `stamps` ("2011-09-26 13:02:25.964389445").
inline void writeSyntheticRawDrive(const fs::path& parent, const std::string& name,
                                   const std::vector<std::string>& stamps) {
  const auto calib = syntheticCalib();
  const fs::path drive = parent / name;
  for (const char* sub : {"image_02/data", "image_03/data", "velodyne_points/data"})
    fs::create_directories(drive / sub);
  {
    std::ofstream c2c(parent / "calib_cam_to_cam.txt");
    c2c << "calib_time: 09-Jan-2012 13:57:47\n";
    c2c << "R_rect_00: 1 0 0 0 1 0 0 0 1\n";
    for (int i = 0; i < 4; ++i) {
      c2c << "S_rect_0" << i << ": 640 240\nP_rect_0" << i << ":";
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) c2c << " " << calib.P[i](r, c);
      c2c << "\n";
    }
    std::ofstream v2c(parent / "calib_velo_to_cam.txt");
    v2c << "calib_time: 15-Mar-2012 11:37:16\nR:";
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) v2c << " " << calib.Tr(r, c);
    v2c << "\nT: " << calib.Tr(0, 3) << " " << calib.Tr(1, 3) << " " << calib.Tr(2, 3) << "\n";
    std::ofstream ts(drive / "image_02" / "timestamps.txt");
    for (const auto& stamp : stamps) ts << stamp << "\n";
  }
  cv::Mat img(240, 640, CV_8UC3, cv::Scalar(40, 90, 200));
  for (size_t i = 0; i < stamps.size(); ++i) {
    char id[32];
    std::snprintf(id, sizeof(id), "%010zu", i);
    cv::imwrite((drive / "image_02" / "data" / (std::string(id) + ".png")).string(), img);
    cv::imwrite((drive / "image_03" / "data" / (std::string(id) + ".png")).string(), img);
    tescalib::writeVelodyneBin(
        (drive / "velodyne_points" / "data" / (std::string(id) + ".bin")).string(),
        syntheticScan());
  }
}

}  // namespace tescalib_test
