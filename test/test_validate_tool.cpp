// tescalib_validate run as a user runs it: a generated drive scored with its own calibration, a
// result file with the same extrinsics and a calibration moved by 0.5 deg / 5 cm; its table, its
// JSON, and bad arguments.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "run_command.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/ros/kitti_bag_writer.h"
#include "test_util.h"

using namespace tescalib;
using tescalib_test::TempDir;

namespace {

int runValidate(const std::string& args, std::string* out) {
  return tescalib_test::runCommand(std::string(TESCALIB_VALIDATE_BIN) + " " + args, out);
}

/// DRIVE's calib.txt with T_cam_lidar moved by `d` (perturb()), written to `path`.
void writeMovedCalib(const std::string& drive, const Vector6d& d, const std::string& path) {
  KittiOdometryCalib c = readKittiOdometryCalib(drive + "/calib.txt");
  const StereoRig rig = rigFromOdometryCalib(c);
  // T_cam_lidar = [I | offset] Tr: keep the offset, move the product.
  const Eigen::Isometry3d moved = perturb(rig.T_cam_lidar, d);
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.translation() = rig.T_cam_lidar.translation() - isometryFrom3x4(c.Tr).translation();
  c.Tr = (offset.inverse() * moved).matrix().topRows<3>();
  writeKittiOdometryCalib(path, c);
  ASSERT_LT(poseError(readCheckedOdometryRig(path).T_cam_lidar, moved).norm(), 1e-9);
}

}  // namespace

TEST(ValidateTool, RanksTheRecordingsCalibrationAboveAMovedOneInTableAndJson) {
  TempDir tmp;
  SimOptions o;
  o.frames = 11;
  o.seed = 9;
  const Simulator sim(o);
  const std::string drive = tmp.str() + "/drive";
  sim.writeSequence(drive);
  Vector6d d = Vector6d::Zero();
  d(0) = 0.5 / kDegPerRad;
  d(4) = 0.05;
  writeMovedCalib(drive, d, tmp.str() + "/moved_calib.txt");
  OnlineEstimate e;
  e.T_cam_lidar = sim.rig().T_cam_lidar;
  e.T_right_left = sim.rig().T_right_left;
  std::string msg;
  ASSERT_TRUE(writeCalibrationFiles(tmp.str() + "/est", sim.rig(), e, {}, &msg)) << msg;

  std::string out;
  const std::string json = tmp.str() + "/scores.json";
  ASSERT_EQ(
      runValidate("--sequences " + drive + " --frames 0-10:5 --calib moved=" + tmp.str() +
                      "/moved_calib.txt --calib estimate=" + tmp.str() + "/est.yaml --json " + json,
                  &out),
      0)
      << out;
  EXPECT_NE(out.find("3 frames, 3 calibrations"), std::string::npos) << out;
  EXPECT_NE(out.find("edge_alignment (higher is better)"), std::string::npos) << out;
  EXPECT_NE(out.find("\nmoved "), std::string::npos) << out;
  EXPECT_NE(out.find("0.500 deg / 5.00 cm from recording"), std::string::npos) << out;
  EXPECT_NE(out.find("along which axes each criterion would move it"), std::string::npos);

  std::ifstream in(json);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["higher_is_better"]["edge_alignment"].get<bool>());
  EXPECT_FALSE(j["higher_is_better"]["photometric_residual"].get<bool>());
  EXPECT_FALSE(j["higher_is_better"]["disparity_residual"].get<bool>());
  ASSERT_EQ(j["calibrations"].size(), 3u);
  EXPECT_EQ(j["frames"].size(), 3u);
  const nlohmann::json& rec = j["calibrations"][0];
  const nlohmann::json& moved = j["calibrations"][1];
  const nlohmann::json& est = j["calibrations"][2];
  EXPECT_EQ(rec["name"], "recording");
  EXPECT_EQ(moved["name"], "moved");
  EXPECT_EQ(est["name"], "estimate");
  for (const char* c : {"edge_alignment", "photometric_residual", "disparity_residual"}) {
    const bool higher = j["higher_is_better"][c].get<bool>();
    const double r = rec["scores"][c], m = moved["scores"][c];
    EXPECT_TRUE(higher ? r > m : r < m) << c << ": " << r << " vs " << m;
    EXPECT_TRUE(moved["difference_to_best"][c]["significant"].get<bool>()) << c;
    EXPECT_NEAR(est["scores"][c].get<double>(), r, 1e-9) << c;  // the same extrinsics
    EXPECT_EQ(rec["direction"][c].size(), 6u);
    EXPECT_EQ(rec["frame_scores"][c].size(), 3u);
  }
  EXPECT_NEAR(moved["difference_to_recording"]["rotation_deg"].get<double>(), 0.5, 1e-6);
  EXPECT_NEAR(moved["difference_to_recording"]["translation_m"].get<double>(), 0.05, 1e-6);
  EXPECT_FALSE(rec.contains("optimum"));

  // The optima searched on frame 5, scored on the frames 0 and 10 held out from the search.
  const std::string held = tmp.str() + "/held.json";
  ASSERT_EQ(
      runValidate("--sequences " + drive + " --frames 0,10 --fit-frames 5 --json " + held, &out), 0)
      << out;
  EXPECT_NE(out.find("the optima searched on 1 other frames, scored on these"), std::string::npos)
      << out;
  EXPECT_NE(out.find("held out from its search, it scores better by"), std::string::npos) << out;
  std::ifstream held_in(held);
  const nlohmann::json h = nlohmann::json::parse(held_in);
  EXPECT_EQ(h["optima_fitted_on"], nlohmann::json::array({"drive:5"}));
  EXPECT_EQ(h["frames"], nlohmann::json::array({"drive:0", "drive:10"}));
  const nlohmann::json& opt = h["calibrations"][0]["optimum"]["disparity_residual"];
  EXPECT_EQ(opt["frame_scores"].size(), 2u);
  // One frame pins the disparity residual's optimum near the truth.
  EXPECT_LT(opt["difference"]["rotation_deg"].get<double>(), 0.3) << opt;
  EXPECT_LT(opt["difference"]["translation_m"].get<double>(), 0.05) << opt;
  // One frame says nothing about how far the optimum may lie: no axis is resolved.
  EXPECT_EQ(opt["uncertainty"]["frames"], 1) << opt;
  EXPECT_EQ(opt["uncertainty"]["rank"], 0) << opt;
  EXPECT_TRUE(opt["uncertainty"]["sigma"][0].is_null()) << opt;
  EXPECT_NE(out.find("its 1-sigma uncertainty (1 frames): [ - - - - - - ]"), std::string::npos)
      << out;

  // The same drive as a kitti2bag-style bag: its keyframes (0, 5, 10) score as the folder's.
  writeKittiBag(KittiSequence(drive), tmp.str() + "/drive.bag", KittiBagOptions{});
  const std::string bag_json = tmp.str() + "/bag.json";
  ASSERT_EQ(runValidate("--bag " + tmp.str() + "/drive.bag --json " + bag_json, &out), 0) << out;
  std::ifstream bag_in(bag_json);
  const nlohmann::json b = nlohmann::json::parse(bag_in);
  EXPECT_EQ(b["frames"], nlohmann::json::array({"bag:0", "bag:5", "bag:10"}));
  for (const char* c : {"edge_alignment", "photometric_residual", "disparity_residual"})
    EXPECT_NEAR(b["calibrations"][0]["scores"][c].get<double>(), rec["scores"][c].get<double>(),
                1e-4)
        << c;
}

TEST(ValidateTool, BadArgumentsAndDataAreNamed) {
  TempDir tmp;
  std::string out;
  EXPECT_EQ(runValidate("", &out), 2);
  EXPECT_NE(out.find("usage: rosrun tescalib tescalib_validate"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences x --calib nameless", &out), 2);
  EXPECT_NE(out.find("bad value 'nameless' for --calib (NAME=FILE)"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--calib a=b", &out), 2);
  EXPECT_NE(out.find("give --sequences DIR[,DIR...] or --bag FILE"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences a --bag b", &out), 2);
  EXPECT_NE(out.find("(one of the two)"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--bag " + tmp.str() + "/none.bag", &out), 1);
  EXPECT_NE(out.find("none.bag"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences " + tmp.str() + "/none", &out), 1);
  EXPECT_NE(out.find("tescalib_validate: "), std::string::npos) << out;
  const std::string drive = tmp.str() + "/drive";
  tescalib_test::writeSyntheticSequence(drive, 2);
  EXPECT_EQ(runValidate("--sequences " + drive + " --frames 7-9", &out), 1);
  EXPECT_NE(out.find("--frames 7-9: none of these frames exists"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences " + drive + " --frames 3-1", &out), 1);
  EXPECT_NE(out.find("--frames: bad item '3-1'"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences " + drive + " --calib a=" + tmp.str() + "/no.yaml", &out), 1);
  EXPECT_NE(out.find("no.yaml"), std::string::npos) << out;
  EXPECT_EQ(runValidate("--sequences " + drive + " --json " + tmp.str() + "/no/x.json", &out), 2);
  EXPECT_NE(out.find("does not exist"), std::string::npos) << out;
}
