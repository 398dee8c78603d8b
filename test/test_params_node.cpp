// rostest: every shipped config/*.yaml loads and validates; invalid values are named.
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <ros/ros.h>

#include "tescalib/ros/params.h"

TEST(Params, ShippedConfigLoadsAndValidates) {
  ros::NodeHandle pnh("~kitti");
  tescalib::NodeParams p;
  // Valid values other than the shipped file's (most of which equal the compiled-in defaults):
  // a key absent from the file keeps these, so each value checked below was read from the file
  // into its own field (with the defaults as start values, a loader that read nothing would
  // pass).
  p.online.window_size = 7;
  p.online.keyframe_min_dt = 0.9;
  p.online.max_time_jump_back = 0.3;
  p.initial_tf_camera_frame = "sentinel_camera";
  p.left_frame = "sentinel_left";
  p.online.co.yaw_handover_deg = 0.7;
  p.online.co.stereo_from_features = false;
  p.online.co.lidar.check_window_halves = false;
  p.online.co.lidar.halves_chi2_limit = 30.0;
  p.halves_start = "initial";
  p.online.co.lidar.halves_start = tescalib::HalvesStart::kInitialGuess;
  p.online.co.lidar.measure_disparity_offset = false;
  p.online.co.lidar.search_step_deg = 5.0;
  p.online.search_min_keyframes = 4;
  p.online.keyframe.mesh.consistent_sample = true;
  p.online.co.lidar.ring_cluster_rings = 5;
  p.online.co.lidar.ring_range_sigma_m = 0.7;
  p.online.deskew = true;
  p.online.deskew_max_dt = 0.4;
  p.max_stereo_skew = 0.04;
  p.online.max_row_offset_px = 0.9;
  p.online.align_rows = false;
  p.online.align_rows_min_px = 0.2;
  p.online.image_quality.min_contrast = 3.0;
  p.online.image_quality.max_clipped_difference = 0.7;
  p.online.keyframe.stereo.equalize_exposure_ratio = 1.5;
  p.online.image_quality.min_sharpness_ratio = 0.5;
  p.online.sweep.clockwise = false;
  p.online.keyframe.stereo.refinement.iterations = 4;
  p.online.keyframe.stereo.refinement.smoothed_gradient_rounds = 3;
  p.online.co.stereo_cloud.refinement.iterations = 3;
  p.online.co.stereo_cloud.refinement.smoothed_gradient_rounds = 2;
  p.online.keyframe.stereo.num_disparities = 64;
  p.image_transport = "compressed";
  std::string error;
  std::vector<std::string> unknown{"not cleared"};
  EXPECT_TRUE(tescalib::loadNodeParams(pnh, &p, &error, &unknown)) << error;
  // Every key of the shipped config is one the node reads.
  EXPECT_TRUE(unknown.empty()) << unknown.front();
  EXPECT_EQ(p.online.window_size, 10);
  EXPECT_DOUBLE_EQ(p.online.keyframe_min_dt, 0.5);
  EXPECT_DOUBLE_EQ(p.online.max_time_jump_back, 0.0);
  EXPECT_EQ(p.initial_tf_camera_frame, "");  // the left camera_info's frame_id
  EXPECT_EQ(p.left_frame, "tescalib_left");
  EXPECT_DOUBLE_EQ(p.online.co.yaw_handover_deg, 0.2);
  EXPECT_TRUE(p.online.co.stereo_from_features);
  EXPECT_TRUE(p.online.co.lidar.check_window_halves);
  EXPECT_DOUBLE_EQ(p.online.co.lidar.halves_chi2_limit, 22.46);
  EXPECT_EQ(p.halves_start, "recheck");
  EXPECT_EQ(p.online.co.lidar.halves_start, tescalib::HalvesStart::kEstimateThenInitialGuess);
  EXPECT_TRUE(p.online.co.lidar.measure_disparity_offset);
  EXPECT_DOUBLE_EQ(p.online.co.lidar.search_step_deg, 10.0);
  EXPECT_EQ(p.online.search_min_keyframes, 8);
  EXPECT_FALSE(p.online.keyframe.mesh.consistent_sample);
  EXPECT_EQ(p.online.co.lidar.ring_cluster_rings, 2);
  EXPECT_DOUBLE_EQ(p.online.co.lidar.ring_range_sigma_m, 0.0);
  EXPECT_FALSE(p.online.deskew);  // KITTI odometry scans are compensated already
  EXPECT_DOUBLE_EQ(p.online.deskew_max_dt, 0.25);
  EXPECT_DOUBLE_EQ(p.max_stereo_skew, 0.02);
  EXPECT_EQ(p.image_transport, "raw");
  EXPECT_DOUBLE_EQ(p.online.max_row_offset_px, 0.5);
  EXPECT_TRUE(p.online.align_rows);
  EXPECT_DOUBLE_EQ(p.online.align_rows_min_px, 0.05);
  EXPECT_DOUBLE_EQ(p.online.image_quality.min_contrast, 8.0);
  EXPECT_DOUBLE_EQ(p.online.image_quality.max_clipped_difference, 0.4);
  EXPECT_DOUBLE_EQ(p.online.keyframe.stereo.equalize_exposure_ratio, 1.15);
  EXPECT_DOUBLE_EQ(p.online.image_quality.min_sharpness_ratio, 0.75);
  EXPECT_TRUE(p.online.sweep.clockwise);
  EXPECT_EQ(p.online.keyframe.stereo.refinement.iterations, 2);
  EXPECT_EQ(p.online.keyframe.stereo.refinement.smoothed_gradient_rounds, 1);
  EXPECT_EQ(p.online.co.stereo_cloud.refinement.iterations, 1);
  EXPECT_EQ(p.online.co.stereo_cloud.refinement.smoothed_gradient_rounds, 0);
  EXPECT_EQ(p.online.keyframe.stereo.num_disparities, 128);
  EXPECT_EQ(p.online.co.stereo_cloud.num_disparities, p.online.keyframe.stereo.num_disparities);
  EXPECT_EQ(p.online.keyframe.stereo.sgbm_paths, 3);
  EXPECT_EQ(p.online.co.stereo_cloud.sgbm_paths, p.online.keyframe.stereo.sgbm_paths);
  EXPECT_TRUE(p.online.keyframe.stereo.sgbm_both_ways);
  EXPECT_TRUE(p.online.co.stereo_cloud.sgbm_both_ways);
  EXPECT_DOUBLE_EQ(p.online.keyframe.stereo.rectified_vertical_blur_px, 0.8);
  EXPECT_DOUBLE_EQ(p.online.co.stereo_cloud.rectified_vertical_blur_px, 0.0);
}

TEST(Params, KittiYamlHoldsTheCompiledInDefaults) {
  // One source of defaults: the core's settings structs. config/kitti.yaml (the user parameters)
  // and config/expert.yaml (the expert ones), both loaded here, spell them out for users to copy
  // and change, so every value they set equals the compiled-in one.
  const std::map<std::string, std::string> defaults = tescalib::nodeParamValues({});
  tescalib::NodeParams p;
  ros::NodeHandle pnh("~kitti");
  std::string error;
  ASSERT_TRUE(tescalib::loadNodeParams(pnh, &p, &error)) << error;
  const std::map<std::string, std::string> loaded = tescalib::nodeParamValues(p);
  ASSERT_EQ(loaded.size(), defaults.size());
  int in_file = 0;
  for (const auto& [name, value] : defaults) {
    if (!pnh.hasParam(name)) continue;
    ++in_file;
    EXPECT_EQ(loaded.at(name), value) << name << " in config/kitti.yaml differs from the default";
  }
  EXPECT_GT(in_file, 40);  // the files set most parameters
  // The list is what the loader reads: a value the loader changes shows in it.
  tescalib::NodeParams changed;
  changed.online.window_size = 7;
  EXPECT_EQ(tescalib::nodeParamValues(changed).at("window/size"), "7");
  EXPECT_EQ(defaults.at("window/size"), "10");
}

TEST(Params, WithoutAConfigTheNodeRunsLidarStereoAsDocumented) {
  // LiDAR-stereo only is the node's default (OnlineSettings::estimate_stereo), as doc/parameters.md
  // and config/kitti.yaml say.
  tescalib::NodeParams p;
  EXPECT_FALSE(p.online.estimate_stereo);
  EXPECT_FALSE(p.online.joint);
  // ... and the shipped file says so itself (it is read into the field: a start value of true
  // becomes false).
  p.online.estimate_stereo = true;
  p.online.joint = true;
  ros::NodeHandle pnh("~kitti");
  std::string error;
  std::vector<std::string> unknown;
  ASSERT_TRUE(tescalib::loadNodeParams(pnh, &p, &error, &unknown)) << error;
  EXPECT_FALSE(p.online.estimate_stereo);
  EXPECT_FALSE(p.online.joint);
}

TEST(Params, LiveProfileLoadsOverTheDefaults) {
  ros::NodeHandle pnh("~live");
  tescalib::NodeParams p;
  std::string error;
  std::vector<std::string> unknown;
  EXPECT_TRUE(tescalib::loadNodeParams(pnh, &p, &error, &unknown)) << error;
  EXPECT_TRUE(unknown.empty()) << unknown.front();
  EXPECT_TRUE(p.online.deskew);
  EXPECT_TRUE(p.online.estimate_stereo);
  EXPECT_EQ(p.online.window_size, 10);  // from config/kitti.yaml
}

TEST(Params, MisspelledKeysAreReported) {
  ros::NodeHandle pnh("~typo");
  pnh.setParam("sync/max_skw", 0.1);
  pnh.setParam("window/size", 12);
  pnh.setParam("stereo/refine/iterations", 1);
  pnh.setParam("stereo/equalize_exposure_ratio", 1.5);
  pnh.setParam("compressed/mode", std::string("unchanged"));  // the transport plugin's own
  tescalib::NodeParams p;
  std::string error;
  std::vector<std::string> unknown;
  EXPECT_TRUE(tescalib::loadNodeParams(pnh, &p, &error, &unknown)) << error;
  EXPECT_EQ(p.online.window_size, 12);
  // The keyframes' stereo settings reach the clouds co-calibration matches again.
  EXPECT_DOUBLE_EQ(p.online.keyframe.stereo.equalize_exposure_ratio, 1.5);
  EXPECT_DOUBLE_EQ(p.online.co.stereo_cloud.equalize_exposure_ratio, 1.5);
  EXPECT_EQ(unknown, (std::vector<std::string>{"stereo/refine/iterations", "sync/max_skw"}));
}

TEST(Params, ASmallWindowIsRefusedOnlyWhereCoCalibrationCouldNotStart) {
  // LiDAR-stereo alone never waits for window/min_keyframes_co (5): a window of 4 is fine there.
  ros::NodeHandle lidar_only("~small_lidar_stereo");
  lidar_only.setParam("window/size", 4);
  tescalib::NodeParams p;
  std::string error;
  EXPECT_TRUE(tescalib::loadNodeParams(lidar_only, &p, &error)) << error;
  EXPECT_EQ(p.online.window_size, 4);
  // With co-calibration it would never co-calibrate.
  ros::NodeHandle co("~small_co");
  co.setParam("window/size", 4);
  co.setParam("co_calibration/estimate_stereo", true);
  error.clear();
  EXPECT_FALSE(tescalib::loadNodeParams(co, &p, &error));
  EXPECT_NE(error.find("window/min_keyframes_co must be in [1, window/size] with "
                       "co_calibration/estimate_stereo (got 5, window/size 4)"),
            std::string::npos)
      << error;
}

TEST(Params, InvalidValuesAreNamed) {
  ros::NodeHandle pnh("~bad");
  pnh.setParam("stereo/num_disparities", 100);
  pnh.setParam("window/size", 0);
  pnh.setParam("initial/T_cam_lidar", std::vector<double>{1, 2, 3});
  pnh.setParam("co_calibration/yaw_handover_deg", 0.0);
  pnh.setParam("co_calibration/joint", true);  // without estimate_stereo (false by default)
  pnh.setParam("lidar_stereo/halves_chi2_limit", -1.0);
  pnh.setParam("lidar_stereo/halves_start", std::string("initial_guess"));
  pnh.setParam("deskew/max_dt", 0.0);
  pnh.setParam("deskew/rate_hz", -10.0);
  pnh.setParam("stereo/refine_iterations", 1);
  pnh.setParam("stereo/refine_smoothed_rounds", 2);
  pnh.setParam("co_calibration/refine_iterations", 7);
  pnh.setParam("lidar_stereo/search_deg", 45.0);
  pnh.setParam("images/min_sharpness_ratio", 1.0);  // [1, 1]: nothing would pass
  pnh.setParam("images/max_clipped_difference", 0.0);
  pnh.setParam("image_transport", std::string("/left/image_raw/compressed"));  // a topic
  tescalib::NodeParams p;
  std::string error;
  EXPECT_FALSE(tescalib::loadNodeParams(pnh, &p, &error));
  EXPECT_NE(error.find("stereo/num_disparities"), std::string::npos) << error;
  EXPECT_NE(error.find("window/size"), std::string::npos) << error;
  EXPECT_NE(error.find("co_calibration/yaw_handover_deg"), std::string::npos) << error;
  EXPECT_NE(error.find("co_calibration/joint (the one-problem co-calibration) needs "
                       "co_calibration/estimate_stereo: true"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("images/min_sharpness_ratio must be in [0, 1)"), std::string::npos) << error;
  EXPECT_NE(error.find("images/max_clipped_difference must be in (0, 1]"), std::string::npos)
      << error;
  EXPECT_NE(error.find("lidar_stereo/halves_chi2_limit"), std::string::npos) << error;
  EXPECT_NE(
      error.find("lidar_stereo/halves_start must be recheck, estimate, initial or always (got "
                 "'initial_guess')"),
      std::string::npos)
      << error;
  EXPECT_NE(error.find("image_transport must be a transport's name"), std::string::npos) << error;
  EXPECT_NE(error.find("deskew/max_dt must be > 0"), std::string::npos) << error;
  EXPECT_NE(error.find("deskew/rate_hz must be > 0"), std::string::npos) << error;
  EXPECT_NE(error.find("stereo/refine_smoothed_rounds must be between 0 and stereo/"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("co_calibration/refine_iterations must be between 0 and 5 (got 7)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("lidar_stereo/search_deg must be between 0 (off) and 20 deg (got 45)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("initial/T_cam_lidar must be [x, y, z, qx, qy, qz, qw] (7 values, got 3)"),
            std::string::npos)
      << error;
}

TEST(Params, ValuesThatWouldRejectEveryFrameAreNamed) {
  // Unchecked, these would let the node start and then reject every keyframe with a message about
  // the images, or every solve for too few associations.
  ros::NodeHandle pnh("~bad2");
  pnh.setParam("stereo/max_depth", 0.0);
  pnh.setParam("lidar_stereo/max_depth", -5.0);
  pnh.setParam("lidar_stereo/normal_weight", 0.0);  // the solver refuses 0 too
  pnh.setParam("lidar_stereo/lidar_range_sigma", 0.0);
  pnh.setParam("photometric/huber", 0.0);
  pnh.setParam("window/max_time_jump_back", -0.1);
  pnh.setParam("initial/T_cam_lidar", std::vector<double>{0, 0, 0, 0, 0, 0, 0});
  pnh.setParam("initial/T_right_left", std::vector<double>{0, 0, 0, 0, 0, 0, 1});
  tescalib::NodeParams p;
  std::string error;
  EXPECT_FALSE(tescalib::loadNodeParams(pnh, &p, &error));
  for (const char* named :
       {"stereo/max_depth must be beyond the stereo clouds' near limit of 2 m (got 0)",
        "lidar_stereo/max_depth must be > 0 m (got -5)",
        "lidar_stereo/normal_weight must be > 0 (got 0)",
        "lidar_stereo/lidar_range_sigma must be > 0", "photometric/huber must be > 0",
        "initial/T_cam_lidar's quaternion", "window/max_time_jump_back must be >= 0 s (got -0.1)",
        "initial/T_right_left must have a baseline"})
    EXPECT_NE(error.find(named), std::string::npos) << named << " in: " << error;
  // A non-finite entry: .nan in YAML.
  ros::NodeHandle nan_pnh("~bad3");
  nan_pnh.setParam("initial/T_cam_lidar", std::vector<double>{0, std::nan(""), 0, 0, 0, 0, 1});
  EXPECT_FALSE(tescalib::loadNodeParams(nan_pnh, &p, &error));
  EXPECT_NE(error.find("initial/T_cam_lidar must hold 7 finite numbers"), std::string::npos)
      << error;
}

TEST(Params, NotANumberAndOtherSilentValuesAreNamed) {
  // Checks written "x <= 0" would let NaN through (keyframe_min_dt NaN makes every frame a
  // keyframe, max_variance_growth NaN switches off the never-publish-worse rule); a max_depth
  // under the clouds' 2 m near limit empties every cloud; a negative perturbation is no size.
  ros::NodeHandle pnh("~bad4");
  const double nan = std::nan("");
  pnh.setParam("window/keyframe_min_dt", nan);
  pnh.setParam("window/max_variance_growth", nan);
  pnh.setParam("sync/max_skew", nan);
  pnh.setParam("stereo/disparity_sigma", std::numeric_limits<double>::infinity());
  pnh.setParam("stereo/max_depth", 1.5);
  pnh.setParam("initial/perturb_rot_deg", -2.0);
  pnh.setParam("window/size", 2);
  pnh.setParam("stereo/block_size", -1);
  pnh.setParam("stereo/sgbm_paths", 4);
  tescalib::NodeParams p;
  std::string error;
  EXPECT_FALSE(tescalib::loadNodeParams(pnh, &p, &error));
  for (const char* named :
       {"window/keyframe_min_dt must be > 0", "window/max_variance_growth must be >= 1",
        "sync/max_skew must be > 0", "stereo/disparity_sigma must be > 0",
        "stereo/max_depth must be beyond the stereo clouds' near limit of 2 m (got 1.5)",
        "initial/perturb_rot_deg and initial/perturb_trans_m must be sizes, >= 0 (got -2, 0)",
        "window/min_keyframes must be in [1, window/size] (got 3, window/size 2)",
        "stereo/block_size must be a positive odd number (got -1)",
        "stereo/sgbm_paths must be 3, 5 or 8 (got 4)"})
    EXPECT_NE(error.find(named), std::string::npos) << named << " in: " << error;
}

TEST(Params, MonitorParametersReachTheCoreAndBadOnesAreNamed) {
  ros::NodeHandle good("~monitor_good");
  good.setParam("monitor/action", std::string("flag"));
  good.setParam("monitor/cusum_h", 90.0);
  good.setParam("monitor/change_span_s", 5.0);
  tescalib::NodeParams p;
  std::string error;
  ASSERT_TRUE(tescalib::loadNodeParams(good, &p, &error)) << error;
  EXPECT_EQ(p.online.monitor.action, "flag");
  EXPECT_DOUBLE_EQ(p.online.monitor.cusum_h, 90.0);
  EXPECT_DOUBLE_EQ(p.online.monitor.change_span_s, 5.0);
  EXPECT_DOUBLE_EQ(p.online.monitor.cusum_k, tescalib::MonitorSettings().cusum_k);
  ros::NodeHandle bad("~monitor_bad");
  bad.setParam("monitor/action", std::string("alarm"));
  bad.setParam("monitor/cusum_k", std::nan(""));
  bad.setParam("monitor/fresh_fraction", 1.5);
  tescalib::NodeParams q;
  EXPECT_FALSE(tescalib::loadNodeParams(bad, &q, &error));
  for (const char* named :
       {"monitor/action must be recalibrate, flag or off (got 'alarm')",
        "monitor/cusum_k must be > 0", "monitor/fresh_fraction must be in (0, 1]"})
    EXPECT_NE(error.find(named), std::string::npos) << named << " in: " << error;
}

TEST(Params, ValuesOfTheWrongTypeAreNamed) {
  // roscpp alone keeps the default for "true" given to a bool and rounds 10.7 to 11.
  ros::NodeHandle pnh("~types");
  pnh.setParam("deskew/enabled", std::string("true"));
  pnh.setParam("sync/max_skew", std::string("0.2"));
  pnh.setParam("frames/left", 5);
  pnh.setParam("window/size", 10.7);
  pnh.setParam("deskew/max_dt", 1);  // an integer where a number is expected is fine
  tescalib::NodeParams p;
  std::string error;
  EXPECT_FALSE(tescalib::loadNodeParams(pnh, &p, &error));
  for (const char* expected : {"deskew/enabled must be true or false (got the string \"true\")",
                               "sync/max_skew must be a number", "frames/left must be a string",
                               "window/size must be an integer"})
    EXPECT_NE(error.find(expected), std::string::npos) << error;
  EXPECT_EQ(error.find("deskew/max_dt"), std::string::npos) << error;
  EXPECT_DOUBLE_EQ(p.online.deskew_max_dt,
                   1.0);  // 10.0 for an integer says it is a decimal (it read "got the number 10").
  pnh.setParam("window/size", 10.0);
  EXPECT_FALSE(tescalib::loadNodeParams(pnh, &p, &error));
  EXPECT_NE(error.find("window/size must be an integer (got the number 10.0 (a decimal))"),
            std::string::npos)
      << error;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_params");
  return RUN_ALL_TESTS();
}
