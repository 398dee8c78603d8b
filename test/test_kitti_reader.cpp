#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/stereo/stereo_cloud.h"
#include "test_util.h"

using namespace tescalib;
using tescalib_test::TempDir;
namespace fs = std::filesystem;

namespace {

/// Expects `fn` to throw DataError whose message contains every fragment.
template <typename Fn>
void expectDataError(Fn fn, std::initializer_list<std::string> fragments) {
  try {
    fn();
    ADD_FAILURE() << "expected a DataError";
  } catch (const DataError& e) {
    const std::string msg = e.what();
    for (const auto& f : fragments)
      EXPECT_NE(msg.find(f), std::string::npos) << msg << " lacks " << f;
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Real KITTI frames

TEST(KittiReaderReal, EverySequenceFramesRingsAndSizes) {
  SKIP_WITHOUT_KITTI();
  const std::map<std::string, std::pair<size_t, cv::Size>> expected = {
      {"00", {10, {1241, 376}}}, {"02", {2, {1241, 376}}}, {"04", {2, {1226, 370}}},
      {"05", {2, {1226, 370}}},  {"06", {2, {1226, 370}}}, {"07", {10, {1226, 370}}}};
  for (const auto& [name, exp] : expected) {
    SCOPED_TRACE("sequence " + name);
    const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/" + name);
    EXPECT_EQ(seq.size(), exp.first);
    EXPECT_EQ(seq.rig().left.width, exp.second.width);
    EXPECT_EQ(seq.rig().left.height, exp.second.height);
    EXPECT_NEAR(seq.rig().baseline(), 0.53, 0.02);
    EXPECT_NEAR(seq.rig().T_right_left.translation().x(), -0.53, 0.02);
    // LiDAR sits about 0.27 m behind and 0.08 m above cam0; cam2 is ~6 cm to its left.
    EXPECT_NEAR(seq.rig().T_cam_lidar.translation().norm(), 0.3, 0.1);
    const auto kf = seq.keyframes(0.5);
    // Ten frames 0.104 s apart: the first and the sixth (0.52 s); two frames (000000 and
    // 000005, 0.52 s apart): both.
    const std::vector<size_t> expected_kf =
        exp.first == 10 ? std::vector<size_t>{0, 5} : std::vector<size_t>{0, 1};
    EXPECT_EQ(kf, expected_kf);
    for (size_t i = 0; i < seq.size(); ++i) {
      const Frame f = seq.load(i);
      EXPECT_EQ(f.left.size(), exp.second);
      EXPECT_EQ(f.right.size(), exp.second);
      EXPECT_EQ(f.left.type(), CV_8UC3);
      EXPECT_GT(f.scan.size(), 100000u);
      std::set<int> rings;
      for (const auto& p : f.scan) rings.insert(p.ring);
      EXPECT_EQ(rings.size(), 64u) << "frame " << f.index;
      EXPECT_EQ(*rings.rbegin(), 63);
      // Ring 0 is the lowest beam: its mean elevation is below ring 63's.
      double e0 = 0, e63 = 0;
      int n0 = 0, n63 = 0;
      for (const auto& p : f.scan) {
        const double e = std::atan2(p.z, std::hypot(p.x, p.y));
        if (p.ring == 0) e0 += e, ++n0;
        if (p.ring == 63) e63 += e, ++n63;
      }
      EXPECT_LT(e0 / n0 * kDegPerRad, -20.0);
      EXPECT_GT(e63 / n63 * kDegPerRad, 0.0);
    }
  }
}

// KITTI's colour cameras are rectified with a baseline that is not purely along x (about 3 mm
// along y): with it, the right image's rows are where the calibration predicts them; taking the
// pair as exactly rectified (the baseline's length along x) leaves them a fraction of a pixel off,
// more the nearer the point (the bottom of the image).
TEST(KittiReaderReal, RightImageRowsAgreeWithTheCalibrationsVerticalBaseline) {
  SKIP_WITHOUT_KITTI();
  const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/04");
  const Frame f = seq.load(0);
  const StereoRig& rig = seq.rig();
  ASSERT_GT(std::fabs(rig.T_right_left.translation().y()), 0.002);
  Eigen::Isometry3d along_x = Eigen::Isometry3d::Identity();
  along_x.translation().x() = -rig.baseline();
  const auto measure = [&](const Eigen::Isometry3d& T) {
    const StereoCloud cloud = computeStereoCloud(f.left, f.right, rig, T);
    const VerticalAlignment v = verticalAlignment(f.left, f.right, cloud, rig, T);
    std::cout << "[ rows     ] " << v.points << " corners, median " << v.median_px << " px, fit "
              << v.offset_px << " + " << v.slope_x_px << " x + " << v.slope_y_px << " y, spread "
              << v.spread_px << "\n";
    return v;
  };
  const VerticalAlignment calib = measure(rig.T_right_left), x_only = measure(along_x);
  EXPECT_GT(calib.points, 1000);
  EXPECT_LT(std::fabs(calib.median_px), 0.05);
  EXPECT_GT(x_only.median_px, 0.08);  // 0.11 px; 0.008 px with the calibration
  EXPECT_GT(x_only.slope_y_px, calib.slope_y_px + 0.3);
}

// Every real pair passes the online node's image check (ImageQualitySettings' defaults) and is
// matched as it is (no contrast equalisation), and the check sees what a user of these cameras
// should know: KITTI's right colour camera is slightly softer than the left (sharpness ratio
// 0.92-0.95 over the 28 pairs), where a blur of 1 px gives 0.74-0.76 and a generated
// pair 1.01.
TEST(KittiReaderReal, EveryPairPassesTheImageCheckAndTheRightCameraIsSlightlySofter) {
  SKIP_WITHOUT_KITTI();
  double lowest = 1e9, highest = 0;
  const StereoSettings stereo;
  for (const std::string name : {"00", "02", "04", "05", "06", "07"}) {
    const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/" + name);
    for (size_t i = 0; i < seq.size(); ++i) {
      const Frame f = seq.load(i);
      SCOPED_TRACE(name + " frame " + std::to_string(f.index));
      ImageQuality l, r;
      EXPECT_EQ(pairQualityProblem(f.left, f.right, ImageQualitySettings{}, &l, &r), "");
      const double ratio = r.sharpness / l.sharpness;
      lowest = std::min(lowest, ratio);
      highest = std::max(highest, ratio);
      EXPECT_GT(std::min(l.contrast, r.contrast), 40);
      EXPECT_LT(std::fabs(r.clipped_fraction - l.clipped_fraction), 0.02);
      // Within StereoSettings::equalize_exposure_ratio: the pair is matched as delivered.
      EXPECT_LT(std::max(r.contrast / l.contrast, l.contrast / r.contrast),
                stereo.equalize_exposure_ratio);
    }
  }
  std::cout << "[ quality  ] right / left sharpness " << lowest << " - " << highest << "\n";
  EXPECT_GT(lowest, 0.85);
  EXPECT_LT(highest, 0.98);
}

// A right camera exposed 1.3x / 1.6x the left (auto-exposure on each camera): on the real frame
// SGBM keeps a fraction of its points unless the grey values are mapped first (3480 and
// 659 of 9509 with a linear mapping's contrast trigger, which saturation fools).
TEST(KittiReaderReal, AnOverExposedRightImageIsEqualisedBeforeMatching) {
  SKIP_WITHOUT_KITTI();
  const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/00");
  const Frame f = seq.load(0);
  const StereoRig& rig = seq.rig();
  const StereoSettings on;
  StereoSettings off;
  off.equalize_exposure_ratio = 0;
  const StereoCloud delivered = computeStereoCloud(f.left, f.right, rig, rig.T_right_left, on);
  EXPECT_FALSE(delivered.exposure_equalized);
  for (const double gain : {1.3, 1.6}) {
    cv::Mat right;
    f.right.convertTo(right, -1, gain, 0);
    const StereoCloud raw = computeStereoCloud(f.left, right, rig, rig.T_right_left, off);
    const StereoCloud eq = computeStereoCloud(f.left, right, rig, rig.T_right_left, on);
    std::cout << "[ exposure ] KITTI 00 right x" << gain << ": " << raw.points.size()
              << " points as is, " << eq.points.size() << " equalised, " << delivered.points.size()
              << " as delivered\n";
    EXPECT_TRUE(eq.exposure_equalized);
    EXPECT_LT(raw.points.size(), 0.5 * delivered.points.size());
    EXPECT_GT(eq.points.size(), 0.7 * delivered.points.size());
  }
}

TEST(KittiReaderReal, GroundTruthPredictsTheStereoDisparityAndAWrongOneDoesNot) {
  SKIP_WITHOUT_KITTI();
  for (const std::string name : {"00", "04", "07"}) {
    SCOPED_TRACE("sequence " + name);
    const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/" + name);
    const Frame f = seq.load(0);
    const auto good =
        lidarDisparityAgreement(f.scan, f.left, f.right, seq.rig(), seq.rig().T_cam_lidar);
    Vector6d delta;
    // Pitch by 2 deg and push half a metre along the optical axis: points land on image rows
    // (and depths) whose disparity differs from the LiDAR's prediction.
    delta << 2.0 / kDegPerRad, 0.0, 0.0, 0.0, 0.0, 0.5;
    const auto bad = lidarDisparityAgreement(f.scan, f.left, f.right, seq.rig(),
                                             perturb(seq.rig().T_cam_lidar, delta));
    std::cout << "[ sequence " << name << " ] ground truth: " << good.points << " points, "
              << good.fraction_within_1px << " within 1 px, global shift " << good.best_global_shift
              << "; wrong: " << bad.fraction_within_1px << " within 1 px, global shift "
              << bad.best_global_shift << "\n";
    EXPECT_GT(good.points, 2000);
    EXPECT_EQ(good.best_global_shift, 0);
    EXPECT_EQ(good.median_shift, 0);
    EXPECT_GT(good.fraction_within_1px, 0.5);
    // Measured: ground truth 0.63-0.83 of the points within 1 px, the wrong extrinsic 0.26-0.30.
    EXPECT_LT(bad.fraction_within_1px, 0.4);
    EXPECT_LT(bad.fraction_within_1px, good.fraction_within_1px - 0.2);
  }
}

// ---------------------------------------------------------------------------------------------
// Synthetic sequences and malformed inputs

TEST(KittiReader, RecoversRingsOfASyntheticScan) {
  auto scan = tescalib_test::syntheticScan(64, 300);
  EXPECT_EQ(recoverRings(scan), 64);
  // Stored top beam first: the first point is ring 63, the last ring 0.
  EXPECT_EQ(scan.front().ring, 63);
  EXPECT_EQ(scan.back().ring, 0);
}

TEST(KittiReader, OdometryLayoutRoundTrip) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 7);
  // Remove one right image: that frame must be skipped, not fail.
  fs::remove(tmp.path / "image_3" / "000003.png");
  const KittiSequence seq(tmp.str());
  EXPECT_EQ(seq.layout(), KittiLayout::kOdometry);
  ASSERT_EQ(seq.size(), 6u);
  EXPECT_EQ(seq.frameId(3), 4);
  EXPECT_NEAR(seq.stamp(3), 0.4, 1e-9);
  EXPECT_EQ(seq.keyframes(0.5), (std::vector<size_t>{0, 4}));  // frame 5 is index 4
  // ... and said (tescalib_check_data prints it).
  EXPECT_EQ(seq.incompleteFrames(), "7 left images, 6 right images, 7 scans");
  EXPECT_EQ(seq.rig().left.width, 640);
  EXPECT_NEAR(seq.rig().T_cam_lidar.translation().x(), 0.02 + 0.06, 1e-9);
  EXPECT_NEAR(seq.rig().T_right_left.translation().x(), -0.54, 1e-9);
  const Frame f = seq.load(0);
  EXPECT_EQ(f.scan.size(), 64u * 400u);
}

TEST(KittiReader, RawLayoutGivesTheSameRigAsOdometry) {
  TempDir tmp;
  const auto calib = tescalib_test::syntheticCalib();
  const fs::path drive = tmp.path / "2011_09_26_drive_0001_sync";
  tescalib_test::writeSyntheticRawDrive(
      tmp.path, drive.filename().string(),
      {"2011-09-26 13:02:25.964389445", "2011-09-26 13:02:26.074807654"});
  const KittiSequence raw(drive.string());
  EXPECT_EQ(raw.layout(), KittiLayout::kRaw);
  ASSERT_EQ(raw.size(), 2u);
  EXPECT_NEAR(raw.stamp(1) - raw.stamp(0), 0.110418209, 1e-6);
  const StereoRig expected = rigFromOdometryCalib(calib);
  EXPECT_LT(poseError(raw.rig().T_cam_lidar, expected.T_cam_lidar).norm(), 1e-9);
  EXPECT_LT(poseError(raw.rig().T_right_left, expected.T_right_left).norm(), 1e-9);
  EXPECT_EQ(raw.load(1).scan.size(), 64u * 400u);
  // A malformed fraction of a second is a DataError, not an escaping std::invalid_argument.
  std::ofstream(drive / "image_02" / "timestamps.txt")
      << "2011-09-26 13:02:25.964389445\n2011-09-26 13:02:26.07x807654\n";
  expectDataError([&] { KittiSequence s(drive.string()); }, {"timestamps.txt:2", "fraction"});
}

TEST(KittiReaderErrors, AbsurdFrameNumbersAndSimInfoAreDataErrors) {
  // Both are DataErrors, not escaping std::out_of_range / std::invalid_argument.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  std::ofstream(tmp.path / "sim_info.txt") << "lidar_sweep: yes\n";
  const KittiSequence seq(tmp.str());
  expectDataError([&] { seq.sweptScans(); }, {"sim_info.txt", "lidar_sweep"});
  std::ofstream(tmp.path / "sim_info.txt") << "lidar_sweep: 1\n";
  EXPECT_TRUE(seq.sweptScans());
  // Leading zeros are fine (KITTI raw pads to 10 digits); ten significant digits are not.
  cv::imwrite((tmp.path / "image_2" / "99999999999.png").string(),
              cv::Mat(240, 640, CV_8UC3, cv::Scalar::all(0)));
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"99999999999.png", "out of range"});
}

TEST(KittiReaderErrors, MissingCalib) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  fs::remove(tmp.path / "calib.txt");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "not found"});
}

TEST(KittiReaderErrors, MalformedCalib) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  {
    std::ofstream c(tmp.path / "calib.txt");
    c << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\n"
         "P2: 700 0 320 0 0 700 120 0 0 0 1\nP3: 700 0 320 0 0 700 120 0 0 0 1 0\n";
  }
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "'P2'", "11 values"});
  {
    std::ofstream c(tmp.path / "calib.txt");
    c << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\n"
         "P2: 700 0 320 0 0 700 120 0 0 0 1 0\nP3: 700 0 320 0 0 700 120 0 0 0 1 0\n";
  }
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "missing key 'Tr'"});
}

TEST(KittiReaderErrors, CalibrationsTheSolversCannotStartFromAreRefused) {
  // Opened, each would give NaN extrinsics or a zero baseline that crashes a solver later.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  const std::string tr = "Tr: 0 -1 0 0.1 0 0 -1 -0.2 1 0 0 -0.3\n";
  auto write = [&](const std::string& text) { std::ofstream(tmp.path / "calib.txt") << text; };
  write("P2: 700 0 320 42 0 0 120 0 0 0 1 0\nP3: 700 0 320 -308 0 700 120 0 0 0 1 0\n" + tr);
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "focal lengths"});
  write("P2: 700 0 320 42 0 700 120 0 0 0 1 0\nP3: 700 0 320 42 0 700 120 0 0 0 1 0\n" + tr);
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "no baseline"});
  write(
      "P2: 700 0 320 42 0 700 120 0 0 0 1 0\nP3: 700 0 320 -308 0 700 120 0 0 0 1 0\n"
      "Tr: 0 0 0 0 0 0 0 0 0 0 0 0\n");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "not a rotation"});
  write("P2: 700 0 320 42 0 700 120 0 0 0 1 0\nP3: 700 0 320 -308 0 700 120 0 0 0 1 0\n" + tr);
  EXPECT_NO_THROW(KittiSequence s(tmp.str()));
}

TEST(KittiReaderErrors, TimesAndCalibrationsAreReadStrictly) {
  // Each of these is refused: a blank line in times.txt would give every later frame the next
  // one's stamp; "0.1abc", "nan" and decreasing stamps are not times; a sheared Tr of determinant
  // 1 would become some other rotation; a P with skew would be read as if it had none.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 3);
  auto times = [&](const std::string& text) { std::ofstream(tmp.path / "times.txt") << text; };
  times("0\n\n0.1\n0.2\n");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"times.txt:3", "blank line 2"});
  times("0\n0.1abc\n0.2\n");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"times.txt:2", "malformed"});
  times("0\nnan\n0.2\n");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"times.txt:2", "malformed"});
  times("0\n0.2\n0.1\n");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"times.txt:3", "do not increase"});
  times("0\n0.1\n0.2\n\n\n");  // blank lines at the end are fine
  EXPECT_EQ(KittiSequence(tmp.str()).size(), 3u);
  auto calib = [&](const std::string& tr, const std::string& p2) {
    std::ofstream(tmp.path / "calib.txt")
        << "P2: " << p2 << "\nP3: 700 0 320 -308 0 700 120 0 0 0 1 0\nTr: " << tr << "\n";
  };
  const std::string p2 = "700 0 320 42 0 700 120 0 0 0 1 0";
  calib("1 0.5 0 0 0 1 0 0 0 0 1 0", p2);  // determinant 1, not a rotation
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "not a rotation"});
  calib("0 -1 0 0.1 0 0 -1 -0.2 1 0 0 -0.3", "700 100 320 42 0 700 120 0 0 0 1 0");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "P2", "skew"});
  calib("0 -1 0 0.1 0 0 -1 -0.2 1 0 0 -0.3", "700 0 320 42 0 700 120 0 0 0 2 0");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"calib.txt", "P2", "last row"});
  calib("0 -1 0 0.1 0 0 -1 -0.2 1 0 0 -0.3", p2);
  EXPECT_NO_THROW(KittiSequence s(tmp.str()));
}

TEST(KittiReader, ARawDriveOpensWithATrailingSlashAndRefusesJunkAfterItsSeconds) {
  // "drive/" (tab completion) must find the calibration beside the drive folder, and
  // "13:02:25garbage" is not 13:02:25.
  TempDir tmp;
  const fs::path drive = tmp.path / "2011_09_26_drive_0001_sync";
  tescalib_test::writeSyntheticRawDrive(
      tmp.path, drive.filename().string(),
      {"2011-09-26 13:02:25.964389445", "2011-09-26 13:02:26.074807654"});
  EXPECT_EQ(KittiSequence(drive.string() + "/").size(), 2u);
  EXPECT_EQ(KittiSequence(drive.string() + "/.").size(), 2u);
  std::ofstream(drive / "image_02" / "timestamps.txt")
      << "2011-09-26 13:02:25\n2011-09-26 13:02:26garbage\n";
  expectDataError([&] { KittiSequence s(drive.string()); }, {"timestamps.txt:2", "malformed"});
  std::ofstream(drive / "image_02" / "timestamps.txt")
      << "2011-09-26 13:02:25\n2011-09-26 13:02:26 \n";  // whole seconds, a trailing blank
  EXPECT_EQ(KittiSequence(drive.string()).size(), 2u);
}

TEST(KittiReaderErrors, FrameNumbersOfMixedWidthsAreNamed) {
  // Each folder has its own file-name width: a frame whose scan is named 1.bin beside 000000.bin
  // is named, not listed and then failing to load.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 3);
  fs::rename(tmp.path / "velodyne" / "000001.bin", tmp.path / "velodyne" / "1.bin");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {"velodyne", "different widths"});
  fs::rename(tmp.path / "velodyne" / "1.bin", tmp.path / "velodyne" / "000001.bin");
  for (int i = 0; i < 3; ++i)
    fs::rename(tmp.path / "velodyne" / ("00000" + std::to_string(i) + ".bin"),
               tmp.path / "velodyne" / ("000000000" + std::to_string(i) + ".bin"));
  expectDataError([&] { KittiSequence s(tmp.str()); },
                  {"velodyne", "10 digits wide", "image_2's 6"});
}

TEST(KittiReader, CalibWithoutTheGreyCamerasIsRead) {
  // tescalib_calibrate --init reads a hand-written file with only what it uses: P2, P3, Tr.
  TempDir tmp;
  {
    std::ofstream c(tmp.path / "calib.txt");
    c << "P2: 700 0 320 42 0 700 120 0 0 0 1 0\nP3: 700 0 320 -308 0 700 120 0 0 0 1 0\n"
         "Tr: 0 -1 0 0.1 0 0 -1 -0.2 1 0 0 -0.3\n";
  }
  const KittiOdometryCalib c = readKittiOdometryCalib((tmp.path / "calib.txt").string());
  EXPECT_EQ(c.P[0], c.P[2]);
  EXPECT_EQ(c.P[1], c.P[3]);
  const StereoRig rig = rigFromOdometryCalib(c);
  EXPECT_NEAR(rig.T_right_left.translation().x(), -0.5, 1e-12);
  EXPECT_NEAR(rig.T_cam_lidar.translation().x(), 0.1 + 0.06, 1e-12);
}

TEST(KittiReaderErrors, TruncatedScan) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  const auto bin = tmp.path / "velodyne" / "000001.bin";
  fs::resize_file(bin, fs::file_size(bin) - 6);
  const KittiSequence seq(tmp.str());
  EXPECT_NO_THROW(seq.load(0));
  expectDataError([&] { seq.load(1); }, {"000001.bin", "truncated"});
}

TEST(KittiReaderErrors, WrongImageSize) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  cv::imwrite((tmp.path / "image_3" / "000001.png").string(),
              cv::Mat(200, 600, CV_8UC3, cv::Scalar::all(0)));
  const KittiSequence seq(tmp.str());
  expectDataError([&] { seq.load(1); }, {"image_3/000001.png", "600x200", "expected 640x240"});
}

TEST(KittiReaderErrors, AWindowOfFoldersMustShareOneCamera) {
  // The same calibration, images of another size: the keyframes would be used with the first
  // folder's intrinsics and size.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str() + "/a", 2);
  tescalib_test::writeSyntheticSequence(tmp.str() + "/b", 2, 320, 240);
  tescalib_test::writeSyntheticSequence(tmp.str() + "/c", 2);
  EXPECT_EQ(openSequences({tmp.str() + "/a", tmp.str() + "/c"}).size(), 2u);
  expectDataError(
      [&] {
        openSequences({tmp.str() + "/a", tmp.str() + "/b"});
      },
      {"/b: images of 320x240", "640x240", "one camera"});
  // A stamp file shorter than the frames: those frames are left out, and said.
  std::ofstream(tmp.str() + "/c/times.txt") << "0.0\n";
  const KittiSequence c(tmp.str() + "/c");
  EXPECT_EQ(c.size(), 1u);
  EXPECT_EQ(c.incompleteFrames(),
            "2 left images, 2 right images, 2 scans; 1 frame without a stamp");
  EXPECT_EQ(KittiSequence(tmp.str() + "/a").incompleteFrames(), "");
}

TEST(KittiReaderErrors, FolderWithoutFrames) {
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str(), 2);
  fs::remove_all(tmp.path / "velodyne");
  expectDataError([&] { KittiSequence s(tmp.str()); }, {tmp.str(), "no frames"});
  expectDataError([&] { KittiSequence s(tmp.str() + "/nope"); }, {"nope", "not found"});
}
