// The calibration files (calibration_io.h) and the offline tool tescalib_calibrate, run as a user
// runs it: on a generated drive with a perturbed start, on real KITTI (where it must refuse to
// write an estimate it does not trust), and on bad arguments.
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <rosbag/bag.h>
#include <sensor_msgs/PointCloud2.h>
#include <nlohmann/json.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/validation/validation.h"
#include "tescalib/ros/kitti_bag_writer.h"
#include "test_util.h"

using namespace tescalib;
using tescalib_test::TempDir;

namespace {

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct ToolRun {
  int status = -1;
  std::string output;  // stdout and stderr
};

ToolRun runTool(const std::string& binary, const std::string& args) {
  ToolRun r;
  const std::string cmd = binary + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 512> buf;
  while (fgets(buf.data(), buf.size(), p)) r.output += buf.data();
  const int status = pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

ToolRun runCalibrate(const std::string& args) { return runTool(TESCALIB_CALIBRATE_BIN, args); }

/// A generated urban drive written to TMP/drive, one frame per keyframe (tescalib_simulate
/// --every 5: the same keyframes and estimates as the 10 Hz drive, a fifth of the rendering); its
/// simulator holds the ground truth.
std::unique_ptr<Simulator> writeDrive(const TempDir& tmp, int frames, uint64_t seed) {
  SimOptions o;
  o.frames = frames;
  o.seed = seed;
  o.write_every = frames >= 5 ? 5 : 1;
  auto sim = std::make_unique<Simulator>(o);
  sim->writeSequence(tmp.str() + "/drive");
  return sim;
}

OnlineEstimate someEstimate() {
  OnlineEstimate e;
  e.T_cam_lidar = perturb(Eigen::Isometry3d::Identity(),
                          (Vector6d() << 1.2, -0.4, 0.3, 0.05, -0.08, -0.27).finished());
  e.T_right_left = perturb(Eigen::Isometry3d::Identity(),
                           (Vector6d() << 0.001, -0.002, 0.0005, -0.54, 0.003, -0.002).finished());
  e.cov_lidar = Matrix6d::Identity() * 1e-6;
  e.cov_lidar(5, 5) = 4e-4;  // sigma 2 cm along z
  e.cov_stereo = Matrix6d::Identity() * 1e-8;
  for (int i = 0; i < 6; ++i) e.observable_lidar[i] = e.observable_stereo[i] = true;
  e.observable_lidar[5] = false;
  e.weakest_lidar.ratio = 2.0;  // tz at 2 cm against the 1 cm limit
  e.weakest_lidar.direction(5) = 1.0;
  e.converged = true;
  e.stereo_estimated = true;
  e.keyframes_used = 7;
  e.windows_averaged = 3;
  e.stamp = 1317384000.123456789;
  return e;
}

}  // namespace

TEST(CalibrationIo, FilesReadBackAsTheEstimate) {
  TempDir tmp;
  const std::string base = tmp.str() + "/result";
  StereoRig rig = rigFromOdometryCalib(tescalib_test::syntheticCalib());
  const OnlineEstimate e = someEstimate();
  CalibrationFrames frames;
  frames.lidar = "my_lidar";
  std::string msg;
  ASSERT_TRUE(writeCalibrationFiles(base, rig, e, frames, &msg)) << msg;
  EXPECT_NE(msg.find("result_static_tf.launch"), std::string::npos) << msg;

  // The KITTI file gives back both extrinsics (the right camera's translation in P3; its
  // rotation, which a rectified P3 cannot hold, in tescalib's extra R_right_left line) and the
  // rig's intrinsics.
  const StereoRig back = rigFromOdometryCalib(readKittiOdometryCalib(base + "_calib.txt"));
  EXPECT_LT(poseError(back.T_cam_lidar, e.T_cam_lidar).norm(), 1e-9);
  EXPECT_LT(poseError(back.T_right_left, e.T_right_left).norm(), 1e-9);
  EXPECT_GT(Eigen::AngleAxisd(e.T_right_left.linear()).angle(), 1e-4);  // a rotated pair
  EXPECT_NE(readAll(base + "_calib.txt").find("R_right_left:"), std::string::npos);
  EXPECT_NEAR(back.left.fx, rig.left.fx, 1e-9);

  const std::string yaml = readAll(base + ".yaml");
  EXPECT_NE(yaml.find("converged: true"), std::string::npos);
  EXPECT_NE(yaml.find("keyframes_used: 7"), std::string::npos);
  EXPECT_NE(yaml.find("windows_averaged: 3"), std::string::npos);
  EXPECT_NE(yaml.find("stamp: 1317384000.123456"), std::string::npos) << yaml;  // not 1.3e9
  EXPECT_NE(yaml.find("child_frame: my_lidar"), std::string::npos);
  EXPECT_NE(yaml.find("sigma_trans_m: [0.001, 0.001, 0.02]"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("trusted_axes: [true, true, true, true, true, false]"), std::string::npos);
  EXPECT_NE(
      yaml.find("  weakest_direction:\n    ratio_to_trust_limit: 2\n    in_words: \"1.00 tz\""),
      std::string::npos)
      << yaml;

  // A T_right_left that was not estimated is trusted on no axis, as on the topics.
  OnlineEstimate given = e;
  given.stereo_estimated = false;
  const std::string y2 = calibrationYaml(given, frames);
  const std::string stereo_block = y2.substr(y2.find("T_right_left:"));
  EXPECT_NE(stereo_block.find("estimated: false"), std::string::npos) << y2;
  EXPECT_NE(stereo_block.find("trusted_axes: [false, false, false, false, false, false]"),
            std::string::npos)
      << y2;

  // tf's parent -> child transform is T_parent_child: the LiDAR's pose in the left camera's
  // inverse, i.e. the camera's position in the LiDAR frame.
  const std::string launch = readAll(base + "_static_tf.launch");
  const Eigen::Vector3d t = e.T_cam_lidar.inverse().translation();
  std::istringstream args(launch.substr(launch.find("args=\"") + 6));
  double x, y, z;
  args >> x >> y >> z;
  EXPECT_NEAR(x, t.x(), 1e-9);
  EXPECT_NEAR(y, t.y(), 1e-9);
  EXPECT_NEAR(z, t.z(), 1e-9);
  EXPECT_NE(launch.find(" my_lidar tescalib_left\"/>"), std::string::npos) << launch;
}

TEST(CalibrationIo, TheResultYamlReadsBackAsTheEstimate) {
  TempDir tmp;
  const std::string base = tmp.str() + "/result";
  OnlineEstimate e = someEstimate();
  CalibrationFrames frames;
  frames.lidar = "my_lidar";
  std::string msg;
  ASSERT_TRUE(writeCalibrationFiles(base, rigFromOdometryCalib(tescalib_test::syntheticCalib()), e,
                                    frames, &msg))
      << msg;
  const CalibrationFile f = readCalibrationYaml(base + ".yaml");
  EXPECT_LT(poseError(f.T_cam_lidar, e.T_cam_lidar).norm(), 1e-9);
  EXPECT_LT(poseError(f.T_right_left, e.T_right_left).norm(), 1e-9);
  EXPECT_TRUE(f.cov_lidar_known && f.cov_stereo_known);
  EXPECT_LT((f.cov_lidar - e.cov_lidar).norm(), 1e-9 * e.cov_lidar.norm());
  EXPECT_LT((f.cov_stereo - e.cov_stereo).norm(), 1e-9 * e.cov_stereo.norm());
  EXPECT_EQ(f.frames.lidar, "my_lidar");
  EXPECT_EQ(f.frames.left, frames.left);
  EXPECT_EQ(f.frames.right, frames.right);
  EXPECT_TRUE(f.converged);
  EXPECT_NEAR(f.stamp, e.stamp, 1e-6);

  // An unknown covariance (null) reads back as unknown, not as numbers.
  e.cov_stereo_known = false;
  std::ofstream(base + "_unknown.yaml") << calibrationYaml(e, frames);
  EXPECT_FALSE(readCalibrationYaml(base + "_unknown.yaml").cov_stereo_known);
  EXPECT_TRUE(readCalibrationYaml(base + "_unknown.yaml").cov_lidar_known);

  // What is not a result file is named with the file.
  std::ofstream(base + "_bad.yaml") << "T_cam_lidar:\n  translation: [1, 2]\n";
  try {
    readCalibrationYaml(base + "_bad.yaml");
    ADD_FAILURE() << "a translation of two numbers was read";
  } catch (const DataError& err) {
    EXPECT_NE(std::string(err.what()).find("_bad.yaml: T_cam_lidar.translation"), std::string::npos)
        << err.what();
  }
  EXPECT_THROW(readCalibrationYaml(base + "_missing.yaml"), DataError);
}

TEST(CalibrationIo, UnwritableFolderIsNamed) {
  std::string msg;
  EXPECT_FALSE(writeCalibrationFiles("/nonexistent_folder/result", StereoRig{}, someEstimate(),
                                     CalibrationFrames{}, &msg));
  EXPECT_NE(msg.find("the folder \"/nonexistent_folder\" does not exist (nothing written)"),
            std::string::npos)
      << msg;
  TempDir tmp;
  // BASE.yaml is BASE (the ~save service's callers wrote result.yaml.yaml).
  ASSERT_TRUE(writeCalibrationFiles(tmp.str() + "/named.yaml", StereoRig{}, someEstimate(),
                                    CalibrationFrames{}, &msg))
      << msg;
  EXPECT_TRUE(std::filesystem::exists(tmp.path / "named.yaml")) << msg;
  EXPECT_TRUE(std::filesystem::exists(tmp.path / "named_calib.txt")) << msg;
  EXPECT_FALSE(std::filesystem::exists(tmp.path / "named.yaml.yaml")) << msg;
  EXPECT_FALSE(writeCalibrationFiles(tmp.str() + "/", StereoRig{}, someEstimate(),
                                     CalibrationFrames{}, &msg));
  EXPECT_NE(msg.find("names a folder"), std::string::npos) << msg;
  // A set that cannot be completed leaves nothing behind (the last file cannot be written).
  std::filesystem::create_directory(tmp.path / "result_static_tf.launch.tmp");
  EXPECT_FALSE(writeCalibrationFiles(tmp.str() + "/result", StereoRig{}, someEstimate(),
                                     CalibrationFrames{}, &msg));
  EXPECT_FALSE(std::filesystem::exists(tmp.path / "result.yaml")) << msg;
  EXPECT_FALSE(std::filesystem::exists(tmp.path / "result.yaml.tmp")) << msg;
  EXPECT_FALSE(std::filesystem::exists(tmp.path / "result_calib.txt.tmp")) << msg;
  EXPECT_NE(msg.find("result_static_tf.launch.tmp: Is a directory"), std::string::npos) << msg;
}

TEST(CalibrationIo, AnUnknownCovarianceIsNullAndNotANumberIsYamls) {
  // A placeholder covariance must not be written as sigmas (57 deg, 1 m), nor NaN as "nan",
  // which YAML reads as a string.
  OnlineEstimate e = someEstimate();
  e.cov_stereo_known = false;
  e.cov_lidar(0, 0) = std::nan("");
  const std::string y = calibrationYaml(e, CalibrationFrames{});
  const std::string lidar = y.substr(0, y.find("T_right_left:"));
  const std::string stereo = y.substr(y.find("T_right_left:"));
  EXPECT_NE(lidar.find("covariance_known: true"), std::string::npos) << y;
  EXPECT_NE(lidar.find("sigma_rot_deg: [.nan, "), std::string::npos) << y;
  EXPECT_NE(lidar.find("covariance_phi_tau: [.nan, 0, "), std::string::npos) << y;
  EXPECT_EQ(y.find("nan,"), y.find(".nan,") + 1) << y;  // every NaN spelt .nan
  EXPECT_NE(stereo.find("covariance_known: false"), std::string::npos) << y;
  EXPECT_NE(stereo.find("sigma_rot_deg: null"), std::string::npos) << y;
  EXPECT_NE(stereo.find("covariance_phi_tau: null"), std::string::npos) << y;
  EXPECT_NE(stereo.find("trusted_axes: [false, false, false, false, false, false]"),
            std::string::npos)
      << y;
  EXPECT_EQ(stereo.find("weakest_direction"), std::string::npos) << y;
  // "dir/.yaml" is the folder once ".yaml" is taken off; "." and ".." name folders too.
  TempDir tmp;
  std::string msg;
  for (const char* name : {"/.yaml", "/.", "/.."}) {
    EXPECT_FALSE(writeCalibrationFiles(tmp.str() + name, StereoRig{}, someEstimate(),
                                       CalibrationFrames{}, &msg))
        << name;
    EXPECT_NE(msg.find("names a folder"), std::string::npos) << msg;
  }
  EXPECT_TRUE(std::filesystem::is_empty(tmp.path));
}

TEST(CalibrateTool, RecoversAPerturbedStartOnAGeneratedDrive) {
  TempDir tmp;
  const auto sim = writeDrive(tmp, 36, 7);  // 8 keyframes
  const std::string base = tmp.str() + "/result";
  const ToolRun r = runCalibrate("--sequences " + tmp.str() + "/drive --perturb-rot-deg 2 " +
                                 "--perturb-trans-m 0.2 --seed 3 --window 8 --out " + base +
                                 " --lidar-frame my_velo --overlay " + base + "_overlay.png");
  std::cout << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("initial T_cam_lidar"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("8 keyframes, 0 rejected"), std::string::npos);
  const StereoRig back = rigFromOdometryCalib(readKittiOdometryCalib(base + "_calib.txt"));
  const Vector6d err = poseError(back.T_cam_lidar, sim->rig().T_cam_lidar);
  std::cout << "[ calibrate] error " << err.head<3>().norm() * kDegPerRad << " deg, "
            << err.tail<3>().norm() * 100 << " cm\n";
  EXPECT_LT(err.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(err.tail<3>().norm(), 0.015);
  // The estimate is printed as tf publishes it (the LiDAR frame -> the left camera, T_cam_lidar's
  // inverse), in m, as a quaternion and as roll/pitch/yaw, with one line on its trust.
  const size_t block = r.output.find("LiDAR -> left camera, my_velo -> tescalib_left:\n");
  ASSERT_NE(block, std::string::npos) << r.output;
  double t[3], q[4], rpy[3];
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find("translation [", block),
                        "translation [%lf %lf %lf] m", &t[0], &t[1], &t[2]),
            3);
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find("quaternion (x y z w) [", block),
                        "quaternion (x y z w) [%lf %lf %lf %lf]", &q[0], &q[1], &q[2], &q[3]),
            4);
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find("roll/pitch/yaw [", block),
                        "roll/pitch/yaw [%lf %lf %lf] deg", &rpy[0], &rpy[1], &rpy[2]),
            3);
  const Eigen::Isometry3d T_lidar_cam = back.T_cam_lidar.inverse();
  EXPECT_LT((Eigen::Vector3d(t[0], t[1], t[2]) - T_lidar_cam.translation()).norm(), 1e-4);
  const Eigen::Quaterniond printed(q[3], q[0], q[1], q[2]);
  EXPECT_LT(printed.angularDistance(Eigen::Quaterniond(T_lidar_cam.linear())), 1e-5);
  const Eigen::Matrix3d from_rpy =
      (Eigen::AngleAxisd(rpy[2] / kDegPerRad, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(rpy[1] / kDegPerRad, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(rpy[0] / kDegPerRad, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  EXPECT_LT((from_rpy - T_lidar_cam.linear()).norm(), 1e-5);
  // And as the node's initial guess takes it: T_cam_lidar itself, [x, y, z, qx, qy, qz, qw].
  const size_t init_at = r.output.find("as the node's initial/T_cam_lidar (the inverse): [", block);
  ASSERT_NE(init_at, std::string::npos) << r.output;
  double p[7];
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find('[', init_at),
                        "[%lf, %lf, %lf, %lf, %lf, %lf, %lf]", &p[0], &p[1], &p[2], &p[3], &p[4],
                        &p[5], &p[6]),
            7);
  EXPECT_LT((Eigen::Vector3d(p[0], p[1], p[2]) - back.T_cam_lidar.translation()).norm(), 1e-4);
  EXPECT_LT(Eigen::Quaterniond(p[6], p[3], p[4], p[5])
                .angularDistance(Eigen::Quaterniond(back.T_cam_lidar.linear())),
            1e-5);
  EXPECT_NE(r.output.find("  trusted: ", block), std::string::npos) << r.output;
  const std::string yaml = readAll(base + ".yaml");
  EXPECT_NE(yaml.find("converged: true"), std::string::npos);
  // The quality scores of the estimate and of the 2 deg / 20 cm initial guess (doc/validation.md):
  // printed and in the YAML, which still reads back; the estimate is significantly better.
  for (const char* c : {"edge_alignment", "photometric_residual", "disparity_residual"}) {
    const size_t line = r.output.find(std::string("  ") + c + " ");
    ASSERT_NE(line, std::string::npos) << r.output;
    EXPECT_NE(r.output.find("for the initial guess (", line), std::string::npos);
    EXPECT_EQ(r.output.find("better, significant)", line), r.output.find(")\n", line) - 19)
        << r.output.substr(line, 120);
    EXPECT_NE(yaml.find(std::string("  ") + c + ": {estimate: "), std::string::npos) << yaml;
  }
  EXPECT_NE(yaml.find("quality:\n  keyframes: 8\n"), std::string::npos) << yaml;
  EXPECT_LT(poseError(readCalibrationYaml(base + ".yaml").T_cam_lidar, back.T_cam_lidar).norm(),
            1e-6);
  // Each estimate's NEES against the truth: the last one printed is the written estimate's,
  // e^T P^-1 e with its covariance (over [phi; tau] as the yaml says), and the mean is given.
  const size_t cov_at = yaml.find("covariance_phi_tau: [", yaml.find("T_cam_lidar:"));
  ASSERT_NE(cov_at, std::string::npos) << yaml;
  std::istringstream cov_in(yaml.substr(cov_at + std::strlen("covariance_phi_tau: [")));
  Matrix6d cov;
  for (int i = 0; i < 36; ++i) {
    cov_in >> cov(i / 6, i % 6);
    cov_in.ignore(1);  // ", " or "]"
  }
  ASSERT_TRUE(cov_in) << yaml;
  const double nees_written = err.dot(cov.ldlt().solve(err));
  const size_t printed_at = r.output.rfind(", NEES ");
  ASSERT_NE(printed_at, std::string::npos) << r.output;
  const double nees_printed = std::stod(r.output.substr(printed_at + std::strlen(", NEES ")));
  std::cout << "[ calibrate] NEES " << nees_printed << " printed, " << nees_written
            << " from the written estimate\n";
  EXPECT_NEAR(nees_printed, nees_written, 0.05 + 0.02 * nees_written);
  EXPECT_NE(r.output.find("published T_cam_lidar against the data's calibration"),
            std::string::npos);
  EXPECT_NE(readAll(base + "_static_tf.launch").find(" my_velo tescalib_left\"/>"),
            std::string::npos);
  // The last keyframe twice, the scan drawn with the initial guess and with the estimate.
  const cv::Mat overlay = cv::imread(base + "_overlay.png");
  ASSERT_FALSE(overlay.empty()) << r.output;
  EXPECT_EQ(overlay.cols, sim->rig().left.width);
  EXPECT_EQ(overlay.rows, 2 * sim->rig().left.height);
}

/// A generated drive (31 frames, 7 keyframes) calibrated from 2 deg / 0.2 m off twice, from its
/// folder and from its bag written with `o`; the bag run writes TMP/result*.
struct BagAndFolder {
  std::unique_ptr<Simulator> sim;
  ToolRun folder, bag;
  StereoRig back;  ///< read from the bag run's result_calib.txt
};

void calibrateBagAndFolder(const TempDir& tmp, const KittiBagOptions& o, BagAndFolder* r) {
  r->sim = writeDrive(tmp, 31, 8);
  writeKittiBag(KittiSequence(tmp.str() + "/drive"), tmp.str() + "/drive.bag", o);
  r->folder =
      runCalibrate("--sequences " + tmp.str() + "/drive --perturb-rot-deg 2 --perturb-trans-m 0.2");
  r->bag = runCalibrate("--bag " + tmp.str() + "/drive.bag --perturb-rot-deg 2 " +
                        "--perturb-trans-m 0.2 --out " + tmp.str() + "/result");
  std::cout << r->bag.output;
  ASSERT_EQ(r->folder.status, 0) << r->folder.output;
  ASSERT_EQ(r->bag.status, 0) << r->bag.output;
  EXPECT_NE(r->bag.output.find("7 keyframes, 0 rejected"), std::string::npos);
  // The generator's pair is rectified along x: camera_info's baseline is the whole extrinsic, so
  // bag and folder give the same estimate.
  const auto last = [](const std::string& out) {
    return out.substr(out.find("error against the data's calibration"), 90);
  };
  EXPECT_EQ(last(r->bag.output), last(r->folder.output));
  r->back = rigFromOdometryCalib(readKittiOdometryCalib(tmp.str() + "/result_calib.txt"));
  const Vector6d err = poseError(r->back.T_cam_lidar, r->sim->rig().T_cam_lidar);
  EXPECT_LT(err.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(err.tail<3>().norm(), 0.015);
}

TEST(CalibrateTool, StartsFromTheNodesFormOfTheInitialGuess) {
  // --init x,y,z,qx,qy,qz,qw: T_cam_lidar as the node's initial/T_cam_lidar (and the printout's
  // line) gives it; here the truth moved 3 cm along the camera's x. The errors are then printed
  // against it: the estimate ends about 3 cm back along -x.
  TempDir tmp;
  const auto sim = writeDrive(tmp, 36, 7);  // 8 keyframes
  const Eigen::Isometry3d T = sim->rig().T_cam_lidar;
  const Eigen::Quaterniond q(T.linear());
  char pose[256];
  std::snprintf(pose, sizeof pose, "%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f", T.translation().x() + 0.03,
                T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
  const ToolRun r = runCalibrate("--sequences " + tmp.str() + "/drive --window 8 --init " + pose);
  ASSERT_EQ(r.status, 0) << r.output;
  const size_t at = r.output.find("change from the initial guess: [");
  ASSERT_NE(at, std::string::npos) << r.output;
  double rot[3], cm[3];
  ASSERT_EQ(std::sscanf(r.output.c_str() + at,
                        "change from the initial guess: [%lf %lf %lf] deg, [%lf %lf %lf] cm",
                        &rot[0], &rot[1], &rot[2], &cm[0], &cm[1], &cm[2]),
            6)
      << r.output;
  EXPECT_NEAR(cm[0], -3.0, 1.0) << r.output;
  EXPECT_LT(std::hypot(cm[1], cm[2]), 1.5) << r.output;
}

TEST(CalibrateTool, CalibratesFromABagAsFromItsFolder) {
  // The same drive as a kitti2bag-style bag: intrinsics from camera_info, the initial guess from
  // /tf_static, the sets read in order without playing the bag.
  TempDir tmp;
  BagAndFolder r;
  ASSERT_NO_FATAL_FAILURE(calibrateBagAndFolder(tmp, KittiBagOptions{}, &r));
  EXPECT_NE(r.bag.output.find("7 clouds, 7 left and 7 right images, 7 synchronized sets"),
            std::string::npos);
}

TEST(CalibrateTool, CalibratesAKitti2bagLaidOutBagAsItsFolder) {
  // The bag as kitti2bag's raw mode writes it: the initial guess through imu_link on
  // /tf_static, bgr8 images, x y z i clouds whose rings must be recovered, the left camera_info's
  // P with KITTI's cam0 offset. The estimate and the result files' LiDAR frame must be those of
  // the folder and of the bag.
  TempDir tmp;
  KittiBagOptions o;
  o.like_kitti2bag = true;
  o.velo_frame = "velodyne";  // not kitti2bag's name: the result files must take the bag's
  BagAndFolder r;
  ASSERT_NO_FATAL_FAILURE(calibrateBagAndFolder(tmp, o, &r));
  // The pair's baseline from the camera_infos is the generator's, not the right P[3] alone.
  EXPECT_LT((r.back.T_right_left.translation() - r.sim->rig().T_right_left.translation()).norm(),
            1e-6);
  std::ifstream launch(tmp.str() + "/result_static_tf.launch");
  const std::string text((std::istreambuf_iterator<char>(launch)), {});
  EXPECT_NE(text.find("velodyne"), std::string::npos) << text;
  EXPECT_EQ(text.find("velo_link"), std::string::npos) << text;
}

TEST(CalibrateTool, JointModeCalibratesBothExtrinsics) {
  // --mode joint: both extrinsics in one Ceres problem (OnlineSettings::joint), the stereo pair
  // 0.1 deg / 1 cm off as the data's calib.txt gives it (--init), the LiDAR 2 deg / 0.2 m.
  TempDir tmp;
  const auto sim = writeDrive(tmp, 26, 9);  // 6 keyframes
  OnlineEstimate init;  // written as tescalib writes a result (R_right_left: the rotation)
  init.T_cam_lidar = sim->rig().T_cam_lidar;
  std::mt19937_64 rng(5);
  init.T_right_left =
      perturb(sim->rig().T_right_left, randomPerturbation(0.1 / kDegPerRad, 0.01, rng));
  writeKittiOdometryCalib(tmp.str() + "/init_calib.txt", calibrationAsKitti(sim->rig(), init));
  const ToolRun r =
      runCalibrate("--sequences " + tmp.str() + "/drive --mode joint --init " + tmp.str() +
                   "/init_calib.txt --perturb-rot-deg 2 " +
                   "--perturb-trans-m 0.2 --seed 4 --window 6 --out " + tmp.str() + "/result");
  std::cout << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("mode joint, window 6"), std::string::npos) << r.output;
  const StereoRig back =
      rigFromOdometryCalib(readKittiOdometryCalib(tmp.str() + "/result_calib.txt"));
  const Vector6d el = poseError(back.T_cam_lidar, sim->rig().T_cam_lidar);
  const Vector6d es = poseError(back.T_right_left, sim->rig().T_right_left);
  const Vector6d es0 = poseError(init.T_right_left, sim->rig().T_right_left);
  std::cout << "[ calibrate] joint: LiDAR " << el.head<3>().norm() * kDegPerRad << " deg, "
            << el.tail<3>().norm() * 100 << " cm; stereo " << es.head<3>().norm() * kDegPerRad
            << " deg, " << es.tail<3>().norm() * 1000 << " mm (from "
            << es0.head<3>().norm() * kDegPerRad << " deg, " << es0.tail<3>().norm() * 1000
            << " mm)\n";
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(el.tail<3>().norm(), 0.015);
  EXPECT_LT(es.head<3>().norm() * kDegPerRad, 0.02);
  EXPECT_LT(es.tail<3>().norm(), 0.003);
  const std::string yaml = readAll(tmp.str() + "/result.yaml");
  const size_t stereo_at = yaml.find("T_right_left:");
  ASSERT_NE(stereo_at, std::string::npos) << yaml;
  EXPECT_NE(yaml.find("estimated: true", stereo_at), std::string::npos) << yaml;
}

TEST(CalibrateTool, MinKeyframesDelaysTheFirstSolve) {
  // The node's window/min_keyframes: no solve (and no line) before the window holds that many.
  TempDir tmp;
  writeDrive(tmp, 31, 8);  // 7 keyframes
  const ToolRun r = runCalibrate("--sequences " + tmp.str() +
                                 "/drive --perturb-rot-deg 1 --perturb-trans-m 0.1 "
                                 "--min-keyframes 5");
  std::cout << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("  keyframe 4 ("), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("  keyframe 5 ("), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("7 keyframes, 0 rejected, 3 solves"), std::string::npos) << r.output;
}

TEST(CalibrateTool, WritesNothingItDoesNotTrust) {
  // Random images (no disparity to match) and a LiDAR sphere: nothing to calibrate on.
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str() + "/seq", 31);
  const ToolRun r =
      runCalibrate("--sequences " + tmp.str() + "/seq --out " + tmp.str() + "/result");
  std::cout << r.output;
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no converged estimate"), std::string::npos) << r.output;
  EXPECT_FALSE(tescalib_test::fs::exists(tmp.str() + "/result.yaml"));
  EXPECT_FALSE(tescalib_test::fs::exists(tmp.str() + "/result_calib.txt"));
}

TEST(CalibrateToolReal, RefusesTheKittiWindowItCannotTrust) {
  SKIP_WITHOUT_KITTI();
  // 2011_09_30's window: the solver measures a +0.2 px disparity offset between KITTI's stereo and
  // LiDAR that leaves the optical axis unconstrained: no estimate written.
  TempDir tmp;
  const std::string k = tescalib_test::kittiDir() + "/sequences/";
  const ToolRun r =
      runCalibrate("--sequences " + k + "04," + k + "05," + k + "06," + k + "07 --out " +
                   tmp.str() + "/result --overlay " + tmp.str() + "/overlay.png");
  std::cout << r.output;
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("8 keyframes, 0 rejected"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("disparity offset"), std::string::npos) << r.output;
  // What the window gave is shown for a look, with the axes it does not trust.
  EXPECT_NE(r.output.find("the last solve's result, not trusted (8 keyframes)"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("  trusted: no - "), std::string::npos) << r.output;
  EXPECT_FALSE(tescalib_test::fs::exists(tmp.str() + "/result.yaml"));
  // The overlay is for a look too: written, with the untrusted solve labelled so.
  EXPECT_NE(r.output.find("overlay written to"), std::string::npos) << r.output;
  EXPECT_EQ(cv::imread(tmp.str() + "/overlay.png").rows, 2 * 370);
}

TEST(CalibrateToolReal, CoCalibratesARecordingShorterThanTheWindowAtItsEnd) {
  SKIP_WITHOUT_KITTI();
  // --mode co on 2011_09_30: 8 keyframes never fill the window of 10 and the LiDAR-first solves
  // are never trusted, so no co-calibration runs before the end of the input: the 8 keyframes
  // are co-calibrated once at the end; the pair's yaw is the +0.035 deg the photometric solver
  // finds on these frames.
  const std::string k = tescalib_test::kittiDir() + "/sequences/";
  const ToolRun r =
      runCalibrate("--sequences " + k + "04," + k + "05," + k + "06," + k + "07 --mode co");
  std::cout << r.output;
  EXPECT_NE(r.output.find("end of the input: 8 keyframes"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("co-calibrating them"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("7 solves"), std::string::npos) << r.output;
  // Printed as tf publishes it, tescalib_left -> tescalib_right (T_right_left's inverse): the
  // turn about the cameras' y axis is tf's pitch, -0.035 deg in that direction.
  const size_t block = r.output.find("left -> right camera, tescalib_left -> tescalib_right:");
  ASSERT_NE(block, std::string::npos) << r.output;
  const size_t at = r.output.find("roll/pitch/yaw [", block);
  ASSERT_NE(at, std::string::npos) << r.output;
  double roll = 0, pitch = 0, yaw = 0;
  ASSERT_EQ(std::sscanf(r.output.c_str() + at, "roll/pitch/yaw [%lf %lf %lf]", &roll, &pitch, &yaw),
            3);
  EXPECT_LT(pitch, -0.02);
  EXPECT_GT(pitch, -0.05);
  EXPECT_LT(std::fabs(yaw), 0.02);
}

// --split K: disjoint parts of one drive calibrated on their own agree within their covariances.
TEST(CalibrateTool, SplitComparesDisjointWindowsByTheirCovariances) {
  TempDir tmp;
  writeDrive(tmp, 51, 5);  // 11 keyframes
  const ToolRun r = runCalibrate("--sequences " + tmp.str() + "/drive --split 2");
  std::cout << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("=== window 2 of 2: keyframes 6-11 of 11 ==="), std::string::npos);
  EXPECT_NE(r.output.find("window 1 (keyframes 1-5): converged"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("window 2 (keyframes 6-11): converged"), std::string::npos) << r.output;
  const size_t pair = r.output.find("windows 1 - 2: [");
  ASSERT_NE(pair, std::string::npos) << r.output;
  double chi2 = -1;
  ASSERT_EQ(std::sscanf(r.output.c_str() + r.output.find("chi2 ", pair), "chi2 %lf", &chi2), 1);
  EXPECT_GT(chi2, 0.0);
  EXPECT_LT(chi2, 30.0);  // two estimates of one truth, each within its covariance
  EXPECT_NE(r.output.find("mean chi2 "), std::string::npos);
}

// --holdout N: every Nth keyframe is left out of the calibration and the estimate, the initial
// guess and the recording's calibration are scored on those, from a folder and from its bag alike.
TEST(CalibrateTool, HoldoutScoresCalibrationsOnKeyframesLeftOut) {
  TempDir tmp;
  const auto sim = writeDrive(tmp, 26, 8);  // 6 keyframes: files 0, 1, ..., 5
  writeKittiBag(KittiSequence(tmp.str() + "/drive"), tmp.str() + "/drive.bag", KittiBagOptions{});
  const std::string start = " --perturb-rot-deg 2 --perturb-trans-m 0.2 --holdout 3";
  const ToolRun folder = runCalibrate("--sequences " + tmp.str() + "/drive" + start + " --out " +
                                      tmp.str() + "/result");
  const ToolRun bag = runCalibrate("--bag " + tmp.str() + "/drive.bag" + start);
  std::cout << folder.output;
  ASSERT_EQ(folder.status, 0) << folder.output;
  ASSERT_EQ(bag.status, 0) << bag.output;
  // Keyframes 3 and 6 (files 2 and 5) are held out: 4 are calibrated on.
  EXPECT_NE(folder.output.find("drive frame 2: held out (--holdout 3)"), std::string::npos);
  EXPECT_NE(folder.output.find("drive frame 5: held out (--holdout 3)"), std::string::npos);
  EXPECT_NE(folder.output.find("\n4 keyframes, 0 rejected"), std::string::npos) << folder.output;
  // The printed block: its title and the indented lines after it.
  const auto heldOutBlock = [](const std::string& out) {
    const size_t at = out.find("held-out scores on ");
    if (at == std::string::npos) return std::string();
    size_t end = out.find('\n', at);
    while (end != std::string::npos && out.compare(end + 1, 2, "  ") == 0)
      end = out.find('\n', end + 1);
    return out.substr(at, end - at);
  };
  const std::string printed = heldOutBlock(folder.output);
  EXPECT_EQ(printed.rfind("held-out scores on 2 keyframes (1 in 3", 0), 0u) << folder.output;
  // The bag holds out the same sets and scores them alike.
  EXPECT_EQ(heldOutBlock(bag.output), printed) << bag.output;
  // BASE.yaml's held_out: the scores of the written estimate and of the truth on files 2 and 5,
  // as ValidationSet gives them; the estimate scores better than the 2 deg / 0.2 m initial guess.
  const std::string yaml = readAll(tmp.str() + "/result.yaml");
  const size_t held = yaml.find("  held_out:\n    keyframes: 2\n    every: 3\n");
  ASSERT_NE(held, std::string::npos) << yaml;
  const KittiSequence seq(tmp.str() + "/drive");
  ValidationSet set({seq.load(2), seq.load(5)}, sim->rig());
  const Eigen::Isometry3d T = readCalibrationYaml(tmp.str() + "/result.yaml").T_cam_lidar;
  const FrameScores est = set.score(T, sim->rig().T_right_left);
  const FrameScores truth = set.score(sim->rig().T_cam_lidar, sim->rig().T_right_left);
  for (Criterion c : kAllCriteria) {
    const std::string key = std::string("    ") + criterionName(c) + ": {estimate: ";
    const size_t at = yaml.find(key, held);
    ASSERT_NE(at, std::string::npos) << yaml;
    double e = 0, initial = 0, recording = 0;
    ASSERT_EQ(std::sscanf(yaml.c_str() + at + key.size(), "%lf, initial_guess: %lf, recording: %lf",
                          &e, &initial, &recording),
              3)
        << yaml.substr(at, 200);
    EXPECT_NEAR(e, summarize(est[int(c)]).mean, 1e-3 * std::fabs(e)) << criterionName(c);
    EXPECT_NEAR(recording, summarize(truth[int(c)]).mean, 1e-5 * std::fabs(recording))
        << criterionName(c);
    EXPECT_TRUE(higherIsBetter(c) ? e > initial : e < initial) << criterionName(c);
    EXPECT_NE(printed.find(std::string("  ") + criterionName(c) + " ("), std::string::npos);
  }
  EXPECT_NO_THROW(readCalibrationYaml(tmp.str() + "/result.yaml"));
}

TEST(CalibrateTool, BadArgumentsAndDataAreNamed) {
  // Usage errors (exit status 2), each named. Numbers are read whole (std::stoi alone took 7.9 as
  // 7), and where the result goes is checked before any work (a folder given as --out must
  // fail before the run, not after it).
  const std::pair<const char*, const char*> usage_errors[] = {
      {"--mode both", "--mode must be lidar_stereo, co or joint"},
      {"--window 2", "--window must be at least 3"},
      {"--window 7.9", "bad value '7.9' for --window"},
      {"--max-skew -1", "--max-skew must be > 0 s"},
      {"--out /tmp/", "names a folder"},
      {"--out /nonexistent_folder/result", "the folder \"/nonexistent_folder\" does not exist"},
      {"--search-deg 45", "--search-deg must be between 0 (off) and 20"},
      {"--split 1", "bad value '1' for --split"},
      {"--split 2 --overlay x.png", "--split goes with --sequences, without --out and --overlay"},
      {"--holdout 1", "bad value '1' for --holdout"},
      {"--holdout 3 --split 2", "--holdout does not go with --split"},
      {"--min-keyframes 0", "--min-keyframes must be between 1 and the window (10)"},
      {"--min-keyframes -1", "--min-keyframes must be between 1 and the window (10)"},
      {"--min-keyframes 11", "--min-keyframes must be between 1 and the window (10)"},
      {"--mode co --min-keyframes 11", "--min-keyframes must be between 1 and the window (10)"},
      {"--window 4 --min-keyframes 5", "--min-keyframes must be between 1 and the window (4)"},
      {"--mode joint --window 4", "--mode joint needs --window 5 or more"},
      {"--max-skew 0.1", "--max-skew is an option of --bag, not of --sequences"},
      {"--points /p", "--points is an option of --bag, not of --sequences"},
      {"--lidar-frame velo", "--lidar-frame names the LiDAR frame in --out's files"},
      {"--init 1,2,3", "bad value '1,2,3' for --init"},
      {"--init 0,0,0,0,0,0,0", "bad value '0,0,0,0,0,0,0' for --init"}};
  for (const auto& [args, why] : usage_errors) {
    const ToolRun u = runCalibrate(std::string(args) + " --sequences x");
    EXPECT_EQ(u.status, 2) << args;
    EXPECT_NE(u.output.find(why), std::string::npos) << args << ": " << u.output;
  }
  ToolRun r = runCalibrate("--sequences /nonexistent_drive");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("/nonexistent_drive"), std::string::npos) << r.output;
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str() + "/seq", 2);
  r = runCalibrate("--sequences " + tmp.str() + "/seq --init " + tmp.str() + "/missing.txt");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("missing.txt"), std::string::npos) << r.output;
  // A result file (BASE.yaml) is an --init too; one that is not is named.
  std::ofstream(tmp.str() + "/bad.yaml") << "converged: true\n";
  r = runCalibrate("--sequences " + tmp.str() + "/seq --init " + tmp.str() + "/bad.yaml");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("bad.yaml: no T_cam_lidar entry"), std::string::npos) << r.output;
  // An --init file is checked as a sequence's calib.txt is: an all-zero Tr is refused up front
  // (not re-orthonormalised into some rotation whose frames would all be rejected).
  KittiOdometryCalib zero = readKittiOdometryCalib(tmp.str() + "/seq/calib.txt");
  zero.Tr.setZero();
  writeKittiOdometryCalib(tmp.str() + "/zero.txt", zero);
  r = runCalibrate("--sequences " + tmp.str() + "/seq --init " + tmp.str() + "/zero.txt");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(
      r.output.find("zero.txt: the LiDAR extrinsic (Tr, or R_rect_00 R | T) is not a rotation"),
      std::string::npos)
      << r.output;
  // image_transport's compressed topic: its camera_info lies beside the image topic above it.
  {
    rosbag::Bag bag(tmp.str() + "/cloud_only.bag", rosbag::bagmode::Write);
    sensor_msgs::PointCloud2 cloud;
    cloud.header.stamp = ros::Time(100.0);
    bag.write("/p", ros::Time(100.0), cloud);
  }
  r = runCalibrate("--bag " + tmp.str() + "/cloud_only.bag --points /p --left " +
                   "/cam/left/image_rect/compressed --right /cam/right/image_rect/compressed");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("camera_info on /cam/left/camera_info and /cam/right/camera_info"),
            std::string::npos)
      << r.output;
}

TEST(EvalTool, RefusesValuesItWouldMisreadOrIgnore) {
  // Each would be misread if accepted: NaN starts would write invalid JSON, a switch is 0 or 1,
  // "8.5x3" is not 8x3, the LiDAR options mean nothing outside stereo mode, and a trial seed must
  // stay within what a JSON reader holds exactly.
  const std::pair<const char*, const char*> usage_errors[] = {
      {"--init-rot-deg nan", "bad value 'nan' for --init-rot-deg"},
      {"--init-trans-m inf", "bad value 'inf' for --init-trans-m"},
      {"--stereo-yaw 7", "bad value '7' for --stereo-yaw"},
      {"--cov-cells 8.5x3", "bad value '8.5x3' for --cov-cells"},
      {"--cov-cells 0x3", "bad value '0x3' for --cov-cells"},
      {"--lidar-sigma 0.1deg,0.02m", "bad value '0.1deg,0.02m' for --lidar-sigma"},
      {"--mode stereo --lidar-sigma 0.1,-1", "bad value '0.1,-1' for --lidar-sigma"},
      {"--first-trial -3", "bad value '-3' for --first-trial"},
      {"--search-deg 45", "bad value '45' for --search-deg"},
      {"--co-model-scale -2", "bad value '-2' for --co-model-scale"},
      {"--coarse-gates 2,0", "bad value '2,0' for --coarse-gates"},
      {"--lidar-rot-deg 1", "options of --mode stereo"},
      {"--mode co --stages fine", "--stages is an option of --mode lidar_stereo"},
      {"--seed 10000000001", "must stay below 2^53"},
      {"--first-trial 2147483647 --trials 2", "must stay below 2^53"}};
  for (const auto& [args, why] : usage_errors) {
    const ToolRun u = runTool(TESCALIB_EVAL_BIN, std::string(args) + " --sequences x");
    EXPECT_EQ(u.status, 2) << args;
    EXPECT_NE(u.output.find(why), std::string::npos) << args << ": " << u.output;
  }
}

TEST(EvalTool, ASolveWithoutACovarianceIsLeftOutOfTheNees) {
  // The LiDAR extrinsic 100 m off leaves the left-right solve no key point: it returns before
  // its covariance. That placeholder (identity) gave a NEES of 0.09 and sigma 57 deg / 1 m.
  TempDir tmp;
  writeDrive(tmp, 3, 8);
  const ToolRun r = runTool(TESCALIB_EVAL_BIN, "--sequences " + tmp.str() +
                                                   "/drive --mode stereo --window 1 --trials 1 "
                                                   "--lidar-trans-m 100 --json " +
                                                   tmp.str() + "/s.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string j = readAll(tmp.str() + "/s.json");
  EXPECT_NE(j.find("\"stereo\": {\"estimated\": true"), std::string::npos) << j;
  EXPECT_NE(j.find("\"sigma_rot_deg\": [null, null, null]"), std::string::npos) << j;
  EXPECT_NE(j.find("\"nees\": null"), std::string::npos) << j;
  EXPECT_NE(j.find("\"mean_nees\": null"), std::string::npos) << j;
  EXPECT_EQ(j.find("57.29"), std::string::npos) << j;
}

TEST(EvalTool, ACoTrialDoesNotDependOnTheTrialsBeforeIt) {
  // Co-calibration keeps its SGBM matches in the keyframes; each trial starts from keyframes of
  // its own, so that trial 1 does not re-triangulate trial 0's matches and --first-trial 1
  // reproduces it.
  TempDir tmp;
  SimOptions o;
  o.frames = 6;
  o.seed = 3;
  o.width = 640, o.height = 300;
  Simulator(o).writeSequence(tmp.str() + "/drive");
  const std::string common =
      "--sequences " + tmp.str() + "/drive --mode co --window 2 --rematch-deg 10 --seed 1 --json ";
  const ToolRun both = runTool(TESCALIB_EVAL_BIN, common + tmp.str() + "/both.json --trials 2");
  ASSERT_EQ(both.status, 0) << both.output;
  const ToolRun one =
      runTool(TESCALIB_EVAL_BIN, common + tmp.str() + "/one.json --trials 1 --first-trial 1");
  ASSERT_EQ(one.status, 0) << one.output;
  // Trial 1's object: the second of the two-trial run, the only one of the other.
  auto trial = [](const std::string& j, int index) {
    size_t at = j.find("\"trials\": [");
    for (int i = 0; i <= index; ++i) at = j.find("{\"seed\": ", at + 1);
    const size_t end = j.find("\"seconds\": {", at);
    return j.substr(at, end - at);
  };
  const std::string a = trial(readAll(tmp.str() + "/both.json"), 1);
  const std::string b = trial(readAll(tmp.str() + "/one.json"), 0);
  ASSERT_NE(a.find("\"seed\": 1000004"), std::string::npos) << a;
  ASSERT_NE(b.find("\"seed\": 1000004"), std::string::npos) << b;
  // The same SGBM work and the same estimates (to the solvers' thread-order rounding).
  auto rematches = [](const std::string& t) {
    const size_t at = t.find("\"rematches\": ");
    return at == std::string::npos ? -1 : std::atoi(t.c_str() + at + 13);
  };
  EXPECT_EQ(rematches(a), rematches(b)) << a << "\n" << b;
  EXPECT_GE(rematches(a), 0) << a;
  auto errors = [](const std::string& t) {
    std::vector<double> v;
    for (size_t at = t.find("_err_"); at != std::string::npos; at = t.find("_err_", at + 1)) {
      double x[3];
      if (std::sscanf(t.c_str() + t.find('[', at), "[%lf, %lf, %lf]", &x[0], &x[1], &x[2]) == 3)
        v.insert(v.end(), x, x + 3);
    }
    return v;
  };
  const std::vector<double> ea = errors(a), eb = errors(b);
  ASSERT_EQ(ea.size(), 12u) << a;  // rot and trans errors of both extrinsics
  ASSERT_EQ(eb.size(), ea.size()) << b;
  for (size_t i = 0; i < ea.size(); ++i) EXPECT_NEAR(ea[i], eb[i], 1e-6) << i;
}

TEST(EvalTool, WritesTheJsonOfTheContract) {
  // The evaluation contract (doc/evaluation.md): every trial has a "lidar" and a "stereo" block
  // with the same fields, the summary both keys. An extrinsic the mode does not estimate says so,
  // and a covariance that does not exist is null, never zeros (which would read as exact).
  TempDir tmp;
  writeDrive(tmp, 11, 8);  // 3 keyframes
  const std::string common = "--sequences " + tmp.str() + "/drive --trials 1 --init-rot-deg 3 " +
                             "--init-trans-m 0.3 --seed 1 --window 3 --search-deg 0 --json ";
  const ToolRun ls = runTool(TESCALIB_EVAL_BIN, common + tmp.str() + "/ls.json");
  ASSERT_EQ(ls.status, 0) << ls.output;
  const std::string j = readAll(tmp.str() + "/ls.json");
  EXPECT_NE(j.find("\"mode\": \"lidar_stereo\", \"method\": \"tescalib\", \"window\": 3"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"lidar\": {\"estimated\": true, \"init_rot_deg\": ["), std::string::npos);
  EXPECT_NE(j.find("\"stereo\": {\"estimated\": false, \"init_rot_deg\": [0, 0, 0]"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"sigma_rot_deg\": [null, null, null]"), std::string::npos);
  EXPECT_NE(j.find("\"summary\": {\"lidar\": {\"median_abs_rot_err_deg\": ["), std::string::npos);
  EXPECT_NE(j.find("\"stereo\": {\"estimated\": false}, \"success_rate\": "), std::string::npos);
  EXPECT_NE(j.find("\"declared_converged_rate\": "), std::string::npos);
  // The run's own settings, so that a JSON says how it was made.
  EXPECT_NE(j.find("\"seed\": 1, \"init_rot_deg\": 3, \"init_trans_m\": 0.3"), std::string::npos)
      << j;
  // A seed is digits (std::stoull wrapped -1 to 2^64 - 1 and read 1.5 as 1).
  for (const char* bad : {"-1", "1.5"}) {
    const ToolRun r = runTool(TESCALIB_EVAL_BIN, common + tmp.str() + "/x.json --seed " + bad);
    EXPECT_EQ(r.status, 2) << bad;
    EXPECT_NE(r.output.find(std::string("bad value '") + bad + "' for --seed"), std::string::npos)
        << r.output;
  }
  EXPECT_NE(j.find("\"seconds\": {\"preprocess\": "), std::string::npos);
  // The GICP baseline has no covariance: null, and no NEES.
  const ToolRun gicp = runTool(TESCALIB_EVAL_BIN, common + tmp.str() + "/g.json --method pcl_gicp");
  ASSERT_EQ(gicp.status, 0) << gicp.output;
  const std::string g = readAll(tmp.str() + "/g.json");
  EXPECT_NE(g.find("\"lidar\": {\"estimated\": true"), std::string::npos) << g;
  EXPECT_NE(g.find("\"covariance\": [null, null"), std::string::npos) << g;
  EXPECT_EQ(g.find("\"covariance\": [0, 0"), std::string::npos) << g;
  EXPECT_NE(g.find("\"mean_nees\": null"), std::string::npos) << g;
  // Nor a measured disparity offset: the keys are there, null (doc/evaluation.md).
  EXPECT_NE(g.find("\"disparity_offset_px\": null, \"disparity_offset_sigma_px\": null, "
                   "\"disparity_offset_used\": null"),
            std::string::npos)
      << g;
  // Measured by the solver's fine stage: a number and a boolean.
  const size_t used = j.find("\"disparity_offset_used\": ");
  ASSERT_NE(used, std::string::npos) << j;
  EXPECT_NE(j.at(used + 25), 'n') << j;
  EXPECT_EQ(j.find("\"disparity_offset_px\": null"), std::string::npos) << j;
  // A baseline of LiDAR-stereo only: asked for another mode, the tool refuses.
  const ToolRun wrong = runTool(
      TESCALIB_EVAL_BIN, common + tmp.str() + "/w.json --mode stereo " + "--method pcl_gicp");
  EXPECT_EQ(wrong.status, 2) << wrong.output;
  EXPECT_NE(wrong.output.find("a baseline of --mode lidar_stereo only"), std::string::npos)
      << wrong.output;
}

TEST(CalibrateTool, TheMonitorHoldsBackEstimatesOnceALidarBumpIsSuspected) {
  // A generated drive whose LiDAR turns 0.5 deg and moves 3 cm at 4 s: the monitor suspects the
  // change within a few s, declares it `changed` and restarts the window; no estimate is published
  // while the change is suspected or sustained (the straddling windows' among them), and one
  // published after the restart is near the truth after the step. --json records every solve with
  // the monitor's state. 12 s of driving: the change is declared 3-4 s after the suspicion (the
  // CUSUM over fresh 5-keyframe windows), and the restarted window needs 2 s more.
  TempDir tmp;
  SimOptions o;
  o.frames = 120;
  o.seed = 21;
  o.write_every = 5;
  o.step.at_s = 4.0;
  o.step.rot_deg = 0.5;
  o.step.trans_m = 0.03;
  const Simulator sim(o);
  sim.writeSequence(tmp.str() + "/drive");
  const Eigen::Isometry3d after =
      rigFromOdometryCalib(readKittiOdometryCalib(tmp.str() + "/drive/calib_after_step.txt"))
          .T_cam_lidar;
  const std::string json = tmp.str() + "/estimates.json";
  const ToolRun r = runCalibrate("--sequences " + tmp.str() + "/drive --window 5 --json " + json);
  std::cout << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("monitor: lidar_to_left suspect at"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("monitor: 1 change(s) found:\n  lidar_to_left changed at"),
            std::string::npos)
      << r.output;
  const nlohmann::json j = nlohmann::json::parse(readAll(json));
  double suspect_at = -1;
  int published_before = 0, published_after = 0;
  ASSERT_GT(j.at("estimates").size(), 10u);
  for (const auto& e : j.at("estimates")) {
    ASSERT_EQ(e.at("extrinsic"), "lidar_to_left");
    ASSERT_EQ(e.at("T").size(), 16u);
    ASSERT_EQ(e.at("covariance").size(), 36u);
    const double t = e.at("time");
    if (e.at("monitor") == "suspect" && suspect_at < 0) suspect_at = t;
    if (!e.at("published")) continue;
    Eigen::Matrix4d T;
    for (int k = 0; k < 16; ++k) T(k / 4, k % 4) = e.at("T")[k];
    const bool later = suspect_at >= 0;
    if (later) {
      ++published_after;
      EXPECT_NE(e.at("monitor"), "suspect") << "published at " << t << " s";
      EXPECT_NE(e.at("monitor"), "changed") << "published at " << t << " s";
    } else if (t >= o.step.at_s) {
      continue;  // a straddling window before the monitor saw the bump
    } else {
      ++published_before;
      EXPECT_EQ(e.at("monitor"), "calibrated");
    }
    const Vector6d err = poseError(Eigen::Isometry3d(T), later ? after : sim.rig().T_cam_lidar);
    EXPECT_LT(err.head<3>().norm() * kDegPerRad, 0.15) << t;
    EXPECT_LT(err.tail<3>().norm(), 0.015) << t;
  }
  EXPECT_GT(published_before, 2);
  // While suspect the window keeps the newest keyframes, so the restarted window holds enough of
  // them to recalibrate before the drive ends.
  EXPECT_GE(published_after, 1);
  EXPECT_NE(r.output.find("\n  lidar_to_left calibrated at"), std::string::npos) << r.output;
  EXPECT_GT(suspect_at, o.step.at_s);
  EXPECT_LT(suspect_at, o.step.at_s + 5);
  // tescalib_eval scores the same run against the truth of each estimate's moment.
  const ToolRun score =
      runTool(TESCALIB_EVAL_BIN, "--sequences " + tmp.str() + "/drive --score-estimates " + json +
                                     " --json " + tmp.str() + "/score.json");
  ASSERT_EQ(score.status, 0) << score.output;
  EXPECT_NE(score.output.find("after the step at 4.00 s: suspect +"), std::string::npos)
      << score.output;
  const nlohmann::json l = nlohmann::json::parse(readAll(tmp.str() + "/score.json"))
                               .at("extrinsics")
                               .at("lidar_to_left");
  EXPECT_DOUBLE_EQ(l.at("step_at_s").get<double>(), o.step.at_s);
  EXPECT_NEAR(l.at("suspect_delay_s").get<double>(), suspect_at - o.step.at_s, 1e-9);
  ASSERT_FALSE(l.at("changed_delay_s").is_null());
  EXPECT_GE(l.at("changed_delay_s").get<double>(), suspect_at - o.step.at_s);
  EXPECT_LE(l.at("changed_delay_s").get<double>(), 10.0);
  EXPECT_EQ(l.at("false_changes"), 0);
  EXPECT_EQ(l.at("solves").get<size_t>(), j.at("estimates").size());
  const ToolRun bad =
      runTool(TESCALIB_EVAL_BIN, "--sequences " + tmp.str() + "/drive --score-estimates " +
                                     tmp.str() + "/drive/calib.txt");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("not a tescalib_calibrate --json file"), std::string::npos)
      << bad.output;
}
