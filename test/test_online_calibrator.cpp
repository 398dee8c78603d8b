// The online state machine without ROS: bad input gives a clear message and a safe state, time
// going backwards resets the window, and an estimate is only replaced by a trustworthy one.
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "shared_drive.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/core/online/pair_check.h"
#include "tescalib/core/online/window_solve.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/uncertainty/trust.h"
#include "test_util.h"

using namespace tescalib;

namespace {

/// Online settings that co-calibrate both extrinsics (the default estimates T_cam_lidar only).
OnlineSettings coCalibrating() {
  OnlineSettings s;
  s.estimate_stereo = true;
  return s;
}

StereoRig smallRig() {
  StereoRig rig;
  rig.left.fx = rig.left.fy = 300;
  rig.left.cx = 160, rig.left.cy = 60, rig.left.width = 320, rig.left.height = 120;
  rig.right = rig.left;
  rig.T_right_left.translation() = Eigen::Vector3d(-0.54, 0, 0);
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  rig.T_cam_lidar.linear() = R;
  return rig;
}

Frame syntheticFrame(const StereoRig& rig, double stamp) {
  Frame f;
  f.stamp = stamp;
  f.scan = tescalib_test::syntheticScan(64, 400, 10.0);
  recoverRings(f.scan);
  f.left = cv::Mat(rig.left.height, rig.left.width, CV_8UC3);
  cv::randu(f.left, 0, 255);
  f.right = f.left.clone();
  return f;
}

}  // namespace

TEST(OnlineCalibrator, RejectsBadInputWithAClearMessage) {
  const StereoRig rig = smallRig();
  OnlineCalibrator cal(rig, coCalibrating());
  std::string msg;
  Frame f = syntheticFrame(rig, 10.0);

  Frame empty = f;
  empty.scan.clear();
  EXPECT_EQ(cal.addFrame(empty, 10.0, &msg), FrameResult::kRejected);
  EXPECT_EQ(msg, "empty LiDAR scan");

  Frame wrong_size = f;
  wrong_size.right = cv::Mat(100, 300, CV_8UC3, cv::Scalar::all(0));
  EXPECT_EQ(cal.addFrame(wrong_size, 10.0, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("does not match camera_info 320x120"), std::string::npos) << msg;

  EXPECT_EQ(cal.addFrame(f, 10.3, &msg), FrameResult::kRejected);  // LiDAR 0.3 s off
  EXPECT_NE(msg.find("stamps differ"), std::string::npos) << msg;

  Frame no_rings = f;
  for (auto& p : no_rings.scan) p.ring = 0;  // a cloud whose rings are unusable
  EXPECT_EQ(cal.addFrame(no_rings, 10.0, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("mesh faces"), std::string::npos) << msg;
  EXPECT_EQ(cal.windowFill(), 0u);
  EXPECT_FALSE(cal.estimate().has_value());
}

TEST(OnlineCalibrator, KeyframeSpacingAndTimeGoingBackwards) {
  const StereoRig rig = smallRig();
  OnlineSettings settings = coCalibrating();
  settings.min_stereo_points = 0;  // the synthetic frames have no texture to match
  OnlineCalibrator cal(rig, settings);
  std::string msg;
  ASSERT_EQ(cal.addFrame(syntheticFrame(rig, 10.0), 10.0, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(cal.addFrame(syntheticFrame(rig, 10.2), 10.2, &msg), FrameResult::kTooClose);
  EXPECT_EQ(cal.addFrame(syntheticFrame(rig, 10.5), 10.5, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(cal.windowFill(), 2u);
  // Co-calibration (the core's default) solves LiDAR-stereo first, from 3 keyframes.
  EXPECT_FALSE(cal.solve(&msg));
  EXPECT_NE(msg.find("needs 3"), std::string::npos) << msg;
  // A looping bag: time jumps back, the window is cleared.
  EXPECT_EQ(cal.addFrame(syntheticFrame(rig, 2.0), 2.0, &msg), FrameResult::kReset);
  EXPECT_NE(msg.find("time went backwards"), std::string::npos) << msg;
  EXPECT_EQ(cal.windowFill(), 0u);
  EXPECT_EQ(cal.addFrame(syntheticFrame(rig, 2.1), 2.1, &msg), FrameResult::kKeyframe) << msg;
}

TEST(OnlineCalibratorReal, PublishesOnlyTrustworthyEstimates) {
  SKIP_WITHOUT_KITTI();
  std::vector<Frame> frames;
  StereoRig rig;
  double t = 100.0;
  for (const char* s : {"04", "05", "06", "07"}) {
    const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/" + s);
    rig = seq.rig();
    for (size_t i : seq.keyframes(0.5)) {
      frames.push_back(seq.load(i));
      frames.back().stamp = t;
      t += 0.5;
    }
  }
  const StereoRig truth = rig;
  std::mt19937_64 rng(2);
  rig.T_cam_lidar = perturb(rig.T_cam_lidar, randomPerturbation(2.0 / kDegPerRad, 0.2, rng));
  OnlineSettings settings;
  settings.estimate_stereo = false;  // LiDAR-stereo only: converges on these frames
  settings.window_size = 8;
  // On these real frames the residuals are correlated: the cluster-robust sigma along camera x
  // and z is ~1.1 cm, above the default 1 cm trust limit. This test is about the never-worse
  // rule, so it accepts axes up to 2 cm, and clusters the residuals by image cell alone (by LiDAR
  // ring too, the sigmas of these 8 keyframes grow past 2 cm: nothing would be published).
  settings.co.lidar.max_sigma_trans_m = 0.02;
  settings.co.lidar.ring_cluster_rings = 0;
  std::string msg;
  auto publishesNothing = [&](const OnlineSettings& s, const std::string& because) {
    OnlineCalibrator checked(rig, s);
    for (const auto& f : frames)
      ASSERT_EQ(checked.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
    EXPECT_FALSE(checked.solve(&msg));
    EXPECT_NE(msg.find(because), std::string::npos) << msg;
    EXPECT_FALSE(checked.estimate().has_value());
    // What the window gave is kept for a look, with the reason it was not published: the same
    // point about 10 cm from KITTI's calibration from every start (doc/limitations.md).
    const auto candidate = checked.lastSolve();
    ASSERT_TRUE(candidate.has_value());
    EXPECT_FALSE(candidate->converged);
    EXPECT_EQ(candidate->message, msg);
    EXPECT_EQ(candidate->keyframes_used, 8);
    const Vector6d off = poseError(candidate->T_cam_lidar, truth.T_cam_lidar);
    EXPECT_LT(off.head<3>().norm() * kDegPerRad, 0.3);
    EXPECT_LT(off.tail<3>().norm(), 0.15);
    EXPECT_GT(poseError(candidate->T_cam_lidar, rig.T_cam_lidar).tail<3>().norm(), 0.1);
  };
  // The clouds' disparity is short by about 0.17 px against the LiDAR on these frames:
  // the solver measures that offset in its residuals, and with it the window does not constrain
  // tz. Nothing is published.
  publishesNothing(settings, "disparity offset");
  // Without that, the split-window check sees that the window's two halves (sequences 04+05 and
  // 06+07) disagree far beyond their covariances, scales the covariance and publishes nothing.
  settings.co.lidar.measure_disparity_offset = false;  // the checks one at a time
  publishesNothing(settings, "halves disagree");
  // Without the check, the first estimate is published.
  settings.co.lidar.check_window_halves = false;
  OnlineCalibrator cal(rig, settings);
  for (const auto& f : frames)
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  const auto first = cal.estimate();
  ASSERT_TRUE(first.has_value());
  EXPECT_TRUE(first->converged);
  ASSERT_TRUE(cal.lastSolve().has_value());
  EXPECT_TRUE(cal.lastSolve()->message.empty());  // published: the last solve is the estimate
  EXPECT_LT(poseError(cal.lastSolve()->T_cam_lidar, first->T_cam_lidar).norm(), 1e-12);
  const Vector6d e = poseError(first->T_cam_lidar, truth.T_cam_lidar);
  EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.3);
  EXPECT_LT(e.tail<3>().norm(), 0.15);

  // Now the right camera delivers garbage: no stereo structure. Such keyframes are rejected
  // (noise is far "sharper" than the left image; without that check, their stereo clouds are
  // nearly empty), so they never reach the window.
  ImageQualitySettings no_quality_check;
  no_quality_check.min_contrast = 0;
  no_quality_check.max_clipped_difference = 1;
  no_quality_check.min_sharpness_ratio = 0;
  OnlineSettings points_only = settings;
  points_only.image_quality = no_quality_check;
  OnlineCalibrator cal_points_only(rig, points_only);
  for (auto f : frames) {
    f.stamp = t, t += 0.5;
    f.right = f.right.clone();  // the frames' own images stay for the next part
    cv::randu(f.right, 0, 255);
    EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kRejected);
    EXPECT_NE(msg.find("the left image has much less fine detail than the right one"),
              std::string::npos)
        << msg;  // as the left camera defocused would be, "or a noisy right one"
    EXPECT_EQ(cal_points_only.addFrame(f, f.stamp, &msg), FrameResult::kRejected);
    EXPECT_NE(msg.find("its stereo cloud has only"), std::string::npos) << msg;
  }
  // Without those checks they were taken: the solve must still not replace the estimate.
  OnlineSettings unchecked = points_only;
  unchecked.min_stereo_points = 0;
  OnlineCalibrator garbage(rig, unchecked);
  for (const auto& f : frames) garbage.addFrame(f, f.stamp, &msg);
  ASSERT_TRUE(garbage.solve(&msg)) << msg;
  const auto good = garbage.estimate();
  for (auto f : frames) {
    f.stamp = t, t += 0.5;
    cv::randu(f.right, 0, 255);
    garbage.addFrame(f, f.stamp, &msg);
  }
  EXPECT_FALSE(garbage.solve(&msg));
  EXPECT_FALSE(msg.empty());
  const auto after = garbage.estimate();
  ASSERT_TRUE(after.has_value());
  EXPECT_LT(poseError(after->T_cam_lidar, good->T_cam_lidar).norm(), 1e-12);
  ASSERT_TRUE(garbage.lastSolve().has_value());
  EXPECT_FALSE(garbage.lastSolve()->converged);
  EXPECT_EQ(garbage.lastSolve()->message, msg);
  cal.reset();
  EXPECT_FALSE(cal.lastSolve().has_value());
}

TEST(OnlineCalibratorGenerated, HighwayKeyframesDoNotPushOutTownKeyframes) {
  // Four keyframes of a generated town, then four of a generated highway (the same rig), window
  // of four. By information, the highway keyframes, which add little along the road, must not
  // replace all town keyframes; first-in-first-out would.
  SimOptions town, highway;
  town.frames = highway.frames = 16;
  town.seed = highway.seed = 6;
  highway.scenario = Scenario::kHighway;
  const Simulator town_sim(town), highway_sim(highway);
  std::vector<Frame> frames;
  for (int i = 0; i < 16; i += 5) frames.push_back(town_sim.renderFrame(i));
  for (int i = 0; i < 16; i += 5) frames.push_back(highway_sim.renderFrame(i));
  for (size_t k = 0; k < frames.size(); ++k) frames[k].stamp = 10.0 + 0.5 * k;
  const double first_highway_stamp = frames[4].stamp;
  std::map<std::string, int> town_left;
  for (const std::string selection : {"information", "fifo"}) {
    OnlineSettings settings;
    settings.estimate_stereo = false;
    settings.window_size = 4;
    settings.keyframe_selection = selection;
    // The selection alone: while the monitor suspects a change (which a newer half of two
    // highway keyframes raises here) the window is oldest-first until the suspicion clears
    // (CalibrationMonitor.KeyframesSetAsideWhileSuspectComeBackUnlessBeforeTheChange).
    settings.monitor.action = "off";
    OnlineCalibrator cal(town_sim.rig(), settings);
    std::string msg;
    for (const Frame& f : frames) {
      ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
      if (cal.readyToSolve()) cal.solve(&msg);
    }
    for (double stamp : cal.windowStamps()) town_left[selection] += stamp < first_highway_stamp;
    ASSERT_EQ(cal.windowStamps().size(), 4u);
  }
  std::cout << "[ select   ] town keyframes left in the window: by information "
            << town_left["information"] << ", first in first out " << town_left["fifo"] << "\n";
  EXPECT_EQ(town_left["fifo"], 0);
  EXPECT_GE(town_left["information"], 2);
}

namespace {
/// A co-calibrated online estimate against the generator's truth, with the end-to-end test's
/// LiDAR accuracy (0.2 deg / 3 cm) and 0.02 deg / 5 mm for the stereo pair.
void expectCoAccuracy(const OnlineEstimate& e, const StereoRig& truth, const char* what) {
  const Vector6d el = poseError(e.T_cam_lidar, truth.T_cam_lidar);
  const Vector6d es = poseError(e.T_right_left, truth.T_right_left);
  std::cout << "[ online   ] " << what << ": LiDAR " << el.head<3>().norm() * kDegPerRad
            << " deg / " << el.tail<3>().norm() * 100 << " cm, stereo "
            << es.head<3>().norm() * kDegPerRad << " deg / " << es.tail<3>().norm() * 1000
            << " mm, " << e.co_rounds << " rounds, " << e.solve_seconds << " s\n";
  EXPECT_TRUE(e.stereo_estimated);
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
  EXPECT_LT(es.head<3>().norm() * kDegPerRad, 0.02);
  EXPECT_LT(es.tail<3>().norm(), 0.005);
}

/// Adds the drive's frames first, first + 5, ... (0.5 s apart) below `end`; each must become a
/// keyframe.
void addKeyframes(OnlineCalibrator& cal, const Simulator& sim, int first, int end) {
  std::string msg;
  for (int i = first; i < end; i += 5) {
    const Frame f = sim.renderFrame(i);
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  }
}
/// The generated drive of the co-calibration tests: 21 frames, 5 keyframes 0.5 s apart.
const tescalib_test::SharedDrive& coDrive() { return tescalib_test::sharedUrbanDrive(4, 21); }

/// addKeyframes from a shared drive's frames.
void addKeyframes(OnlineCalibrator& cal, const tescalib_test::SharedDrive& drive, int first,
                  int end) {
  std::string msg;
  for (int i = first; i < end; i += 5) {
    const Frame& f = drive.frame(i);
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  }
}

/// The drive's rig with T_cam_lidar and T_right_left started that far off (random directions).
StereoRig perturbedRig(const Simulator& sim, unsigned seed, double lidar_deg, double lidar_m,
                       double stereo_deg = 0, double stereo_m = 0) {
  StereoRig rig = sim.rig();
  std::mt19937_64 rng(seed);
  rig.T_cam_lidar =
      perturb(rig.T_cam_lidar, randomPerturbation(lidar_deg / kDegPerRad, lidar_m, rng));
  if (stereo_deg > 0 || stereo_m > 0)
    rig.T_right_left =
        perturb(rig.T_right_left, randomPerturbation(stereo_deg / kDegPerRad, stereo_m, rng));
  return rig;
}
}  // namespace

TEST(OnlineCalibratorGenerated, RowsOffTheCalibrationReRectifyThePairOnce) {
  // The right camera turned by hundredths of a degree after rectification (its rows a tenth of a
  // pixel off): with align_rows the first keyframe's rows turn the pair's T_right_left towards
  // the true one, the window restarts with that keyframe matched again, and the next keyframes
  // are matched re-rectified.
  SimOptions o;
  o.frames = 11;
  o.seed = 23;
  ASSERT_EQ(o.realism.set("right_rotation_deg=0.06"), "");
  const Simulator sim(o);
  OnlineSettings settings;
  settings.align_rows = true;
  OnlineCalibrator cal(sim.rig(), settings);
  std::string msg;
  const Frame f0 = sim.renderFrame(0);
  std::shared_ptr<const Keyframe> built;
  EXPECT_EQ(cal.addFrame(f0, f0.stamp, &msg, &built), FrameResult::kKeyframe) << msg;
  EXPECT_NE(msg.find("re-rectified"), std::string::npos) << msg;
  EXPECT_EQ(cal.windowFill(), 1u);
  ASSERT_TRUE(built);
  EXPECT_TRUE(built->T_right_left_used.isApprox(cal.rig().T_right_left));
  const auto pitchRoll = [&](const Eigen::Isometry3d& T) {
    const Eigen::AngleAxisd turn(T.linear() * sim.rig().T_right_left.linear().transpose());
    const Eigen::Vector3d w = turn.angle() * turn.axis() * kDegPerRad;
    return Eigen::Vector2d(w.x(), w.z());
  };
  const Eigen::Vector2d truth = pitchRoll(sim.trueRig().T_right_left);
  const Eigen::Vector2d found = pitchRoll(cal.rig().T_right_left);
  EXPECT_LT((found - truth).norm(), 0.3 * truth.norm())
      << found.transpose() << " vs " << truth.transpose();
  const Eigen::Isometry3d aligned = cal.rig().T_right_left;
  for (int i = 5; i < o.frames; i += 5) {
    const Frame f = sim.renderFrame(i);
    EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  }
  EXPECT_EQ(cal.windowFill(), 3u);
  EXPECT_TRUE(cal.rig().T_right_left.isApprox(aligned));  // once

  // The pair without the rotation: its rows move by less than align_rows_min_px, the first
  // keyframe stays and the pair is not touched.
  o.realism = sim::RealismSizes{};
  const Simulator clean(o);
  OnlineCalibrator kept(clean.rig(), settings);
  const Frame c0 = clean.renderFrame(0);
  EXPECT_EQ(kept.addFrame(c0, c0.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(msg.find("re-rectified"), std::string::npos) << msg;
  EXPECT_TRUE(kept.rig().T_right_left.isApprox(clean.rig().T_right_left));
}

TEST(OnlineCalibratorGenerated, AfterAnUnconvergedSolveTheWarmStartRunsTheCoarseStageAgain) {
  // A published estimate far off (the extrinsic changed beyond the fine stage's basin): the
  // warm start from it runs the fine stage only while the last solve converged, and the coarse
  // stage again after one that did not, which brings the start in.
  SimOptions o;
  o.frames = 40;
  o.seed = 12;
  const Simulator sim(o);
  const StereoRig far = perturbedRig(sim, 5, 6.0, 0.6);
  WindowSolveInput in;
  for (int i = 0; i < o.frames; i += 5)
    in.keyframes.push_back(std::make_shared<Keyframe>(
        makeKeyframe(sim.renderFrame(i), sim.rig(), far.T_cam_lidar, sim.rig().T_right_left)));
  OnlineEstimate published;
  published.T_cam_lidar = in.T_cam_lidar = far.T_cam_lidar;
  published.T_right_left = in.T_right_left = sim.rig().T_right_left;
  published.converged = true;
  in.published = published;
  OnlineSettings settings;
  settings.estimate_stereo = false;
  std::map<bool, WindowSolveResult> r;
  for (bool last_converged : {true, false}) {
    in.last_converged = last_converged;
    r[last_converged] = solveWindow(in, sim.rig(), settings, nullptr);
  }
  auto off = [&sim](const WindowSolveResult& w) {
    const Vector6d e = poseError(w.estimate.T_cam_lidar, sim.rig().T_cam_lidar);
    return std::make_pair(e.head<3>().norm() * kDegPerRad, e.tail<3>().norm());
  };
  for (bool last_converged : {true, false})
    std::cout << "[ warm     ] last solve converged " << last_converged << ": converged "
              << r[last_converged].estimate.converged << ", " << off(r[last_converged]).first
              << " deg / " << off(r[last_converged]).second * 100 << " cm off the truth "
              << r[last_converged].message << "\n";
  EXPECT_FALSE(r[true].estimate.converged);
  ASSERT_TRUE(r[false].estimate.converged) << r[false].message;
  EXPECT_LT(off(r[false]).first, 0.1);
  EXPECT_LT(off(r[false]).second, 0.015);
}

TEST(OnlineCalibratorGenerated, AWarmUpdateGivesTheMonitorAChangedPairsEstimate) {
  // The right camera moved 0.2 deg / 5 mm before the window (a stereo bump), the keyframes'
  // clouds are rectified for the old pair and the published co-calibration is the old truth:
  // the warm update's left-right solve, from the published T_cam_lidar, finds the new pair and
  // says it settled whatever its LiDAR-stereo solve did on the clouds of the old pair, so the
  // calibration monitor has its evidence.
  SimOptions o;
  o.frames = 26;
  o.seed = 14;
  o.step.at_s = 0;
  o.step.rot_deg = 0.2, o.step.trans_m = 0.005, o.step.stereo = true;
  const Simulator sim(o);
  const StereoRig& before = sim.rig();
  const StereoRig& after = sim.rigAfterStep();
  WindowSolveInput in;
  in.co = true;
  for (int i = 0; i < o.frames; i += 5)
    in.keyframes.push_back(std::make_shared<Keyframe>(
        makeKeyframe(sim.renderFrame(i), before, before.T_cam_lidar, before.T_right_left)));
  OnlineEstimate published;
  published.T_cam_lidar = in.T_cam_lidar = before.T_cam_lidar;
  published.T_right_left = in.T_right_left = before.T_right_left;
  published.converged = published.stereo_estimated = true;
  in.published = published;
  const WindowSolveResult r = solveWindow(in, before, coCalibrating(), nullptr);
  const OnlineEstimate& e = r.estimate;
  const Vector6d to_new = poseError(e.T_right_left, after.T_right_left);
  const double chi2_to_old = nees(poseError(e.T_right_left, before.T_right_left), e.cov_stereo);
  std::cout << "[ stereo   ] warm update: converged " << e.converged << " (" << r.message
            << "), left-right " << to_new.head<3>().norm() * kDegPerRad << " deg / "
            << to_new.tail<3>().norm() * 1000 << " mm off the new pair, chi2 " << chi2_to_old
            << " from the old one\n";
  EXPECT_EQ(e.co_rounds, coCalibrating().warm_co_rounds);
  ASSERT_TRUE(r.stereo_settled) << r.message;
  EXPECT_TRUE(e.cov_stereo_known);
  EXPECT_LT(to_new.head<3>().norm() * kDegPerRad, 0.05);
  EXPECT_GT(chi2_to_old, MonitorSettings().cusum_k);
}

// The pair checked on four keyframes alone (pair_check.h), with the published extrinsics those
// before a bump and the LiDAR's covariance that of a co-calibrated window: after a stereo bump of
// 0.2 deg / 5 mm it finds the new pair and lies far beyond the monitor's reference value from
// the old one; without a bump, and after a LiDAR bump of 0.5 deg / 3 cm (its depth then comes
// from the old LiDAR extrinsic), it stays within it.
TEST(OnlineCalibratorGenerated, APairCheckOnTheNewestKeyframesFindsAChangedPair) {
  for (const char* bump : {"stereo", "none", "lidar"}) {
    SimOptions o;
    o.frames = 16;
    o.seed = 15;
    if (std::string(bump) == "stereo")
      o.step.at_s = 0, o.step.rot_deg = 0.2, o.step.trans_m = 0.005, o.step.stereo = true;
    if (std::string(bump) == "lidar")
      o.step.at_s = 0, o.step.rot_deg = 0.5, o.step.trans_m = 0.03, o.step.stereo = false;
    const Simulator sim(o);
    const StereoRig& before = sim.rig();
    const StereoRig& now = o.step.at_s >= 0 ? sim.rigAfterStep() : sim.rig();
    std::vector<std::shared_ptr<const Keyframe>> keyframes;
    for (int i = 0; i < o.frames; i += 5)
      keyframes.push_back(std::make_shared<Keyframe>(
          makeKeyframe(sim.renderFrame(i), before, before.T_cam_lidar, before.T_right_left)));
    OnlineEstimate published;
    published.T_cam_lidar = before.T_cam_lidar;
    published.T_right_left = before.T_right_left;
    published.converged = published.stereo_estimated = true;
    published.cov_lidar_given_stereo = Matrix6d::Zero();
    addAxisVariances(&published.cov_lidar_given_stereo, {0.01, 0.01, 0.01}, {0.003, 0.003, 0.003});
    const std::optional<PairCheck> check =
        checkStereoPair(keyframes, before, published, coCalibrating());
    ASSERT_TRUE(check.has_value()) << bump;
    const Vector6d to_now = poseError(check->T_right_left, now.T_right_left);
    const double chi2_to_old =
        nees(poseError(check->T_right_left, before.T_right_left), check->covariance);
    std::cout << "[ stereo   ] pair check, " << bump
              << " bump: " << to_now.head<3>().norm() * kDegPerRad << " deg / "
              << to_now.tail<3>().norm() * 1000 << " mm off the pair, chi2 " << chi2_to_old
              << " from the published one, " << check->seconds << " s\n";
    EXPECT_EQ(check->stamps.size(), keyframes.size());
    // A keyframe without images or LiDAR is no check, not an exception.
    EXPECT_FALSE(checkStereoPair({std::make_shared<Keyframe>()}, before, published, coCalibrating())
                     .has_value());
    if (std::string(bump) == "stereo") {
      EXPECT_LT(to_now.head<3>().norm() * kDegPerRad, 0.03);
      EXPECT_GT(chi2_to_old, 10 * MonitorSettings().cusum_k);
    } else {
      EXPECT_LT(chi2_to_old, MonitorSettings().cusum_k) << bump;
    }
  }
}

// A pair whose right image sits a pixel lower than camera_info says: the first keyframe is taken
// with a warning that names the offset; the pair as rendered gives none. Checked once.
TEST(OnlineCalibratorGenerated, WarnsWhenTheRightImageRowsDisagreeWithTheCalibration) {
  SimOptions o;
  o.frames = 6;
  o.seed = 1;
  const Simulator sim(o);
  OnlineSettings settings;
  settings.estimate_stereo = false;
  std::string msg;
  Frame f0 = sim.renderFrame(0), f5 = sim.renderFrame(5);
  OnlineCalibrator exact(sim.rig(), settings);
  ASSERT_EQ(exact.addFrame(f0, f0.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_TRUE(msg.empty()) << msg;
  for (Frame* f : {&f0, &f5}) {
    cv::Mat lower;
    const cv::Mat down = (cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, 1.0);
    cv::warpAffine(f->right, lower, down, f->right.size(), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
    f->right = lower;
  }
  OnlineCalibrator shifted(sim.rig(), settings);
  ASSERT_EQ(shifted.addFrame(f0, f0.stamp, &msg), FrameResult::kKeyframe) << msg;
  std::cout << "[ online   ] " << msg << "\n";
  EXPECT_TRUE(msg.find("rows lie +1.0") != std::string::npos ||
              msg.find("rows lie +0.9") != std::string::npos)
      << msg;  // the 1 px moved
  EXPECT_NE(msg.find("enable co-calibration"), std::string::npos) << msg;
  ASSERT_EQ(shifted.addFrame(f5, f5.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_TRUE(msg.empty()) << msg;
}

TEST(OnlineCalibratorGenerated, CoCalibrationPublishesLidarFirst) {
  // With co-calibration and lidar_first: 3 keyframes give a LiDAR-stereo estimate with the stereo
  // pair at its start (not estimated); at min_keyframes_co the first alternation starts from it.
  // The stereo start is 0.02 deg / 2 mm off (a slightly wrong camera_info); with 0.2 deg / 1 cm
  // the LiDAR-stereo solve on the misrectified clouds is flagged unobservable, and nothing is
  // published before the first co-calibration.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 8, 1.0, 0.05, 0.02, 0.002);
  OnlineSettings settings;
  settings.estimate_stereo = true;
  settings.window_size = 6;
  settings.min_keyframes = 3;
  settings.min_keyframes_co = 5;
  // The faces' normals alone: with the stereo surface's derivative (the default) the halves of
  // this 5-keyframe window (2 and 3 keyframes) disagree along the optical axis (chi2 23.3, limit
  // 22.5, 2.2 cm with sigmas of 0.4 cm each) and the first co estimate waits for a longer window.
  settings.co.fine_stereo_normal_px = 0;
  // The keyframes' clouds without the re-rectified pair's vertical low-pass: with it the fine
  // stage of this 3-keyframe solve on the misrectified clouds does not settle within its
  // iteration budget, and the first estimate is co-calibration's.
  settings.keyframe.stereo.rectified_vertical_blur_px = 0.0;
  ASSERT_TRUE(settings.lidar_first);
  EXPECT_EQ(settings.minKeyframes(), 3);
  OnlineCalibrator cal(rig, settings);
  std::string msg;
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 15));
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  auto e = cal.estimate();
  ASSERT_TRUE(e.has_value());
  EXPECT_FALSE(e->stereo_estimated);
  EXPECT_EQ(e->co_rounds, 0);
  // The pair at its start: camera_info's, re-rectified for the rows the first keyframe showed.
  EXPECT_TRUE(e->T_right_left.isApprox(cal.rig().T_right_left));
  EXPECT_EQ(e->cov_stereo.trace(), 0.0);
  const Vector6d el0 = poseError(e->T_cam_lidar, sim.rig().T_cam_lidar);
  std::cout << "[ online   ] LiDAR first, 3 keyframes: " << el0.head<3>().norm() * kDegPerRad
            << " deg / " << el0.tail<3>().norm() * 100 << " cm\n";
  EXPECT_LT(el0.head<3>().norm() * kDegPerRad, 0.5);
  EXPECT_LT(el0.tail<3>().norm(), 0.05);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 15, 25));
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  e = cal.estimate();
  EXPECT_GE(e->co_rounds, 1);
  EXPECT_GT(e->cov_stereo.trace(), 0.0);
  expectCoAccuracy(*e, sim.rig(), "co-calibration from it, 5 keyframes");
  // Given min_keyframes_co keyframes at once, a fresh calibrator still solves LiDAR-stereo first:
  // co-calibration waits for a published LiDAR estimate (or a full window).
  OnlineCalibrator fresh(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(fresh, drive, 0, 25));
  ASSERT_EQ(fresh.windowFill(), 5u);
  ASSERT_TRUE(fresh.solve(&msg)) << msg;
  EXPECT_EQ(fresh.estimate()->co_rounds, 0);
  EXPECT_FALSE(fresh.estimate()->stereo_estimated);
}

TEST(OnlineCalibratorGenerated, JointCoCalibrationStartsFromTheLidarFirstEstimate) {
  // OnlineSettings::joint: co-calibration by the one-problem solve. Its keyframes fit every mesh
  // face's normal (jointCalibrate refuses a window of sampled meshes: converged false, nothing
  // published), and it starts from the LiDAR-first estimate; an update starts from its own.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 8, 1.0, 0.05, 0.02, 0.002);
  OnlineSettings settings;
  settings.estimate_stereo = settings.joint = true;
  settings.window_size = 6;
  OnlineCalibrator cal(rig, settings);
  std::string msg;
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  ASSERT_TRUE(cal.estimate().has_value());
  EXPECT_FALSE(cal.estimate()->stereo_estimated) << "LiDAR first";
  ASSERT_TRUE(cal.coCalibrationPending());
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  auto e = cal.estimate();
  EXPECT_GE(e->co_rounds, 1);
  EXPECT_GT(e->cov_stereo.trace(), 0.0);
  EXPECT_TRUE(e->cov_lidar.isApprox(e->cov_lidar_given_stereo)) << "the joint solve's";
  expectCoAccuracy(*e, sim.rig(), "joint from it, 5 keyframes");
  ASSERT_TRUE(cal.lastSolve().has_value());
  EXPECT_TRUE(cal.lastSolve()->converged);
  // An update (no feature matches: one photometric-first round with the LiDAR-stereo fine stage
  // alone, then the joint problem): converged again, as accurate.
  cal.solve(&msg);
  ASSERT_TRUE(cal.lastSolve().has_value());
  EXPECT_TRUE(cal.lastSolve()->converged) << msg;
  EXPECT_GE(cal.lastSolve()->co_rounds, 1);
  expectCoAccuracy(*cal.lastSolve(), sim.rig(), "joint update from its own estimate");
}

TEST(OnlineCalibratorGenerated, ARecordingShorterThanTheWindowIsCoCalibratedAtItsEnd) {
  // With the stereo pair 0.2 deg / 1 cm off, the LiDAR-first solves on its misrectified clouds
  // are never trusted, and 5 keyframes never fill a window of 10: the node would wait for more,
  // an offline tool at the end of its input co-calibrates what it has (tescalib_calibrate on the
  // 8 keyframes of KITTI 2011_09_30 ended without any co-calibration).
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 7, 1.0, 0.05, 0.2, 0.01);
  OnlineSettings settings;
  settings.estimate_stereo = true;
  settings.window_size = 10;
  OnlineCalibrator cal(rig, settings);
  std::string msg;
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  ASSERT_EQ(cal.windowFill(), 5u);
  EXPECT_TRUE(cal.coCalibrationPending());  // enough keyframes, none co-calibrated yet
  EXPECT_FALSE(cal.solve(&msg));
  ASSERT_TRUE(cal.lastSolve().has_value());
  EXPECT_FALSE(cal.lastSolve()->stereo_estimated) << "LiDAR first, the window is not full";
  EXPECT_FALSE(cal.estimate().has_value()) << msg;
  EXPECT_TRUE(cal.coCalibrationPending());
  ASSERT_TRUE(cal.solve(&msg, nullptr, /*recording_ended=*/true)) << msg;
  const auto e = cal.estimate();
  ASSERT_TRUE(e.has_value());
  EXPECT_TRUE(e->stereo_estimated);
  EXPECT_GE(e->co_rounds, 1);
  expectCoAccuracy(*e, sim.rig(), "co-calibration at the end of 5 keyframes");
  EXPECT_FALSE(cal.coCalibrationPending());
  // LiDAR-stereo only: never pending.
  settings.estimate_stereo = false;
  OnlineCalibrator lidar_only(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(lidar_only, drive, 0, 25));
  lidar_only.solve(&msg);
  EXPECT_FALSE(lidar_only.coCalibrationPending());
}

TEST(OnlineCalibratorGenerated, TheFirstCoEstimateReplacesTheLidarFirstOne) {
  // With camera_info's stereo pair exact, the LiDAR-first estimate's covariance (stereo taken as
  // exact) is narrower than the co-calibrated one's (the clouds' scale and yaw free): the
  // per-axis variance gate (max_variance_growth) alone would refuse every co estimate after it
  // (tescalib_calibrate --mode co would never publish one on generated urban drives). The first co
  // estimate has its own bound, max_variance_growth_first_co (10): published under it, refused
  // with a bound below its growth.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 8, 1.0, 0.05);
  OnlineSettings settings;
  settings.estimate_stereo = true;
  settings.window_size = 6;
  settings.min_keyframes = 3;
  settings.min_keyframes_co = 5;
  // The residuals clustered by image cell alone: clustered by LiDAR ring too, the LiDAR-first
  // covariance on 15 keyframes is as wide as the co estimate's (0.97x at most when measured), and
  // no bound of at least 1 would have a growth to refuse.
  settings.co.lidar.ring_cluster_rings = 0;
  ASSERT_GT(settings.max_variance_growth_first_co, settings.max_variance_growth);
  // The LiDAR-first estimate, then the co-calibrated solve; returns both.
  auto run = [&](const OnlineSettings& s, std::string* msg, bool* co_published) {
    OnlineCalibrator cal(rig, s);
    EXPECT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 15));
    EXPECT_TRUE(cal.solve(msg)) << *msg;
    const OnlineEstimate lidar_first = *cal.estimate();
    EXPECT_FALSE(lidar_first.stereo_estimated);
    EXPECT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 15, 25));
    *co_published = cal.solve(msg);
    return std::make_pair(lidar_first, *cal.lastSolve());
  };
  std::string msg;
  bool published = false;
  const auto [lidar_first, co] = run(settings, &msg, &published);
  EXPECT_TRUE(published) << msg;
  expectCoAccuracy(co, sim.rig(), "first co estimate after a LiDAR-first one, 5 keyframes");
  // Like with like: the gate compares the co estimate's LiDAR covariance given the pair (the
  // pair's own uncertainty, propagated into cov_lidar, has no counterpart in
  // the LiDAR-first one). The published covariance carries it: wider on some axis (the
  // alternation's gain can narrow others, rx 0.91x when measured).
  EXPECT_GT((co.cov_lidar - co.cov_lidar_given_stereo).diagonal().maxCoeff(), 0);
  EXPECT_TRUE(lidar_first.cov_lidar.isApprox(lidar_first.cov_lidar_given_stereo));
  // Some LiDAR axis's variance wider than the LiDAR-first one's (1.45x when measured, the
  // LiDAR-first solve estimating the clouds' scale too).
  const Vector6d ratio =
      co.cov_lidar_given_stereo.diagonal().cwiseQuotient(lidar_first.cov_lidar.diagonal());
  std::cout << "[ online   ] co / LiDAR-first LiDAR variance per axis: " << ratio.transpose()
            << "\n";
  EXPECT_GT(ratio.maxCoeff(), 1.2);
  EXPECT_LT(ratio.maxCoeff(), settings.max_variance_growth_first_co);
  // Its own bound still holds: below the co estimate's growth it is refused, and the LiDAR-first
  // estimate stays.
  OnlineSettings strict = settings;
  strict.max_variance_growth_first_co = 0.9 * ratio.maxCoeff();
  EXPECT_GT(strict.max_variance_growth_first_co, 1.0);
  run(strict, &msg, &published);
  EXPECT_FALSE(published);
  EXPECT_NE(msg.find("less certain than the published one"), std::string::npos) << msg;
}

/// Solves the window in a thread and calls `meanwhile` once the solve has taken its snapshot;
/// returns what solve() returned.
bool solveWhile(OnlineCalibrator& cal, const std::function<void()>& meanwhile, std::string* msg) {
  bool updated = false;
  std::thread solver([&] { updated = cal.solve(msg); });
  // The solve has taken its snapshot once the window is no longer "ready" (no new keyframes).
  while (cal.readyToSolve()) std::this_thread::yield();
  meanwhile();
  solver.join();
  return updated;
}

TEST(OnlineCalibratorGenerated, ATimeJumpBackSeenDuringASolveDiscardsItsResult) {
  // A looping bag: the node's callback sees the clock jump back (noteStamp) while a solve of the
  // old loop's window runs; its result must not be published after the jump, stamped in the
  // future. Stamps that go forward leave the solve alone.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  OnlineSettings settings = coCalibrating();
  settings.window_size = 5;
  // The mechanics of a solve, not its verdict: on five keyframes the halves (two and three
  // keyframes) solved from the initial guess find this window's estimate beyond their limit.
  settings.co.halves_always_from_initial_guess = false;
  const StereoRig rig = perturbedRig(sim, 3, 1.0, 0.1);
  std::string msg;
  OnlineCalibrator back(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(back, drive, 0, 25));
  const double last = back.windowStamps().back();
  EXPECT_FALSE(solveWhile(
      back, [&] { back.noteStamp(last - 5.0); }, &msg));
  EXPECT_NE(msg.find("cleared during the solve"), std::string::npos) << msg;
  EXPECT_FALSE(back.lastSolve().has_value());
  OnlineCalibrator forward(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(forward, drive, 0, 25));
  EXPECT_TRUE(solveWhile(
      forward, [&] { forward.noteStamp(last + 1.0); }, &msg))
      << msg;
  EXPECT_EQ(forward.lastSolve()->solve_id, 1u);
}

TEST(OnlineCalibratorGenerated, AKeyframeBuiltAcrossAResetIsDropped) {
  // ~reset while a keyframe is being built (SGBM and the mesh take 0.1-0.7 s): it was made with
  // the extrinsics of the cleared estimate and must not start the fresh window. The reset comes 20
  // ms into the build; a try where the thread had not yet started is repeated.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  OnlineCalibrator cal(perturbedRig(sim, 3, 1.0, 0.1), coCalibrating());
  const Frame f = drive.frame(0);
  std::string msg;
  FrameResult r = FrameResult::kKeyframe;
  for (int attempt = 0; attempt < 5 && r == FrameResult::kKeyframe; ++attempt) {
    cal.reset();
    std::thread builder([&] { r = cal.addFrame(f, f.stamp, &msg); });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    cal.reset();
    builder.join();
  }
  EXPECT_EQ(r, FrameResult::kRejected) << msg;
  EXPECT_NE(msg.find("cleared while this keyframe was built"), std::string::npos) << msg;
  EXPECT_EQ(cal.windowFill(), 0u);
  // The next frame is taken as usual.
  EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(cal.windowFill(), 1u);
}

TEST(OnlineCalibratorGenerated, AResetDuringASolveDiscardsItsResult) {
  // ~reset while a solve runs: the solve's result belongs to the window that was cleared and
  // must not come back as the published estimate (nor as the warm start of the next window).
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 3, 1.0, 0.1);
  OnlineSettings settings = coCalibrating();
  settings.window_size = 5;
  // The mechanics of a solve, not its verdict: on five keyframes the halves (two and three
  // keyframes) solved from the initial guess find this window's estimate beyond their limit.
  settings.co.halves_always_from_initial_guess = false;
  OnlineCalibrator cal(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  ASSERT_TRUE(cal.readyToSolve());
  std::string msg;
  EXPECT_FALSE(solveWhile(
      cal, [&] { cal.reset(); }, &msg));
  EXPECT_NE(msg.find("cleared during the solve"), std::string::npos) << msg;
  EXPECT_FALSE(cal.estimate().has_value());
  EXPECT_FALSE(cal.lastSolve().has_value());
  // The calibrator goes on: the same keyframes again give an estimate.
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  OnlineEstimate published;
  ASSERT_TRUE(cal.solve(&msg, &published)) << msg;
  ASSERT_TRUE(cal.estimate().has_value());
  EXPECT_TRUE(cal.estimate()->T_cam_lidar.isApprox(published.T_cam_lidar));
  const Vector6d err = poseError(published.T_cam_lidar, sim.rig().T_cam_lidar);
  EXPECT_LT(err.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(err.tail<3>().norm(), 0.03);
}

namespace {
/// Starts a solve on another thread, cancels the calibrator once the solve has taken its window
/// and returns what the solve returned (its message in *msg).
bool solveAndCancelIt(OnlineCalibrator* cal, std::string* msg) {
  bool updated = true;
  std::thread solver([&] { updated = cal->solve(msg); });
  while (cal->readyToSolve()) std::this_thread::yield();
  cal->cancel();
  solver.join();
  return updated;
}
}  // namespace

TEST(OnlineCalibratorGenerated, CancelStopsARunningCoCalibration) {
  // A node shutting down cancels its calibrator: a cold co-calibration (seconds) stops at its
  // next round or re-association, unpublished, and later solves return at once. "cancelled"
  // (not "cancelled after the solve had ended") says the solvers saw the flag: without it wired
  // into the co-calibration's settings this fails.
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 5, 2.0, 0.2, 0.5, 0.05);
  OnlineSettings settings;
  settings.estimate_stereo = true;
  settings.lidar_first = false;
  settings.window_size = 5;
  settings.min_keyframes_co = 5;
  OnlineCalibrator cal(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  std::string msg;
  const auto t0 = std::chrono::steady_clock::now();
  const bool updated = solveAndCancelIt(&cal, &msg);
  std::cout << "[ online   ] cancelled co-calibration returned after "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()
            << " s\n";
  EXPECT_FALSE(updated);
  EXPECT_EQ(msg, "cancelled");
  EXPECT_FALSE(cal.estimate().has_value());
  EXPECT_FALSE(cal.solve(&msg));
  EXPECT_EQ(msg, "cancelled");
}

TEST(OnlineCalibratorGenerated, CancelStopsARunningLidarStereoSolve) {
  // The same for a LiDAR-stereo solve (its wide-basin search runs several starts).
  const tescalib_test::SharedDrive& drive = coDrive();
  const Simulator& sim = drive.sim();
  const StereoRig rig = perturbedRig(sim, 6, 3.0, 0.3, 0.0, 0.0);
  OnlineSettings settings;
  settings.estimate_stereo = false;  // a full window would co-calibrate otherwise
  settings.window_size = 5;
  settings.search_min_keyframes = 5;
  OnlineCalibrator cal(rig, settings);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, drive, 0, 25));
  std::string msg;
  EXPECT_FALSE(solveAndCancelIt(&cal, &msg));
  EXPECT_EQ(msg, "cancelled");
  EXPECT_FALSE(cal.estimate().has_value());
}

TEST(OnlineCalibratorGenerated, CoCalibrationContinuesWarmAfterTheFirstEstimate) {
  // Co-calibration online: the first solve runs the full alternation from a LiDAR extrinsic
  // 1 deg / 5 cm off; the next update (one keyframe more) runs one warm round from the published
  // estimate (photometric on the finest level, LiDAR-stereo fine stage) and is published because
  // both solves converged. Accuracy as the end-to-end test asks: 0.2 deg / 3 cm.
  SimOptions o;
  o.frames = 31;
  o.seed = 4;
  const Simulator sim(o);
  StereoRig rig = sim.rig();
  std::mt19937_64 rng(5);
  rig.T_cam_lidar = perturb(rig.T_cam_lidar, randomPerturbation(1.0 / kDegPerRad, 0.05, rng));
  OnlineSettings settings;
  settings.estimate_stereo = true;
  settings.window_size = 6;
  settings.min_keyframes = 5;
  // The first solve is the full alternation (with LiDAR first it would be a LiDAR-stereo solve:
  // co-calibration waits for its estimate; CoCalibrationPublishesLidarFirst tests that).
  settings.lidar_first = false;
  OnlineCalibrator cal(rig, settings);
  std::string msg;
  auto check = [&](const char* what) {
    const auto e = cal.estimate();
    ASSERT_TRUE(e.has_value());
    expectCoAccuracy(*e, sim.rig(), what);
  };
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, sim, 0, 25));
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  check("full co-calibration, 5 keyframes");
  EXPECT_GT(cal.estimate()->co_rounds, 1);
  ASSERT_NO_FATAL_FAILURE(addKeyframes(cal, sim, 25, 26));
  ASSERT_TRUE(cal.solve(&msg)) << msg;
  check("warm update, 6 keyframes");
  EXPECT_EQ(cal.estimate()->co_rounds, settings.warm_co_rounds);
  // The warm update's LiDAR covariance holds the pair's uncertainty, as the full run's does
  // (the covariance given the pair would be rz sigma 42 % smaller, compared against the full
  // run's with it).
  const OnlineEstimate warm = *cal.estimate();
  EXPECT_GT(warm.cov_lidar(2, 2), 1.2 * warm.cov_lidar_given_stereo(2, 2))
      << "rz variance " << warm.cov_lidar(2, 2) << " vs given the pair "
      << warm.cov_lidar_given_stereo(2, 2);
}

/// A generated drive of raw (swept) scans at 8-14 m/s.
std::unique_ptr<Simulator> sweptDrive(int frames) {
  SimOptions o;
  o.frames = frames;
  o.seed = 3;
  o.lidar_sweep = true;
  return std::make_unique<Simulator>(o);
}

/// LiDAR-stereo only, de-skewing on.
OnlineSettings deskewing() {
  OnlineSettings s;
  s.deskew = true;
  s.estimate_stereo = false;
  return s;
}

/// The largest horizontal distance between a point of `raw` and the same point of `deskewed`.
double largestCorrection(const LidarScan& deskewed, const LidarScan& raw) {
  double moved = 0;
  for (size_t i = 0; i < raw.size(); ++i)
    moved = std::max(moved, double(std::hypot(deskewed[i].x - raw[i].x, deskewed[i].y - raw[i].y)));
  return moved;
}

TEST(OnlineCalibratorGenerated, DeskewsKeyframeScansWithThePreviousScansMotion) {
  // Raw (swept) scans at 8-14 m/s: a keyframe's scan is de-skewed with the velocity registered
  // against the previous scan; without a previous scan, or with one too old, the frame is not
  // taken as a keyframe (the next one can be).
  const auto drive = sweptDrive(12);
  const Simulator& sim = *drive;
  OnlineCalibrator cal(sim.rig(), deskewing());
  std::string msg;
  std::shared_ptr<const Keyframe> kf;
  const Frame f0 = sim.renderFrame(0), f1 = sim.renderFrame(1), f8 = sim.renderFrame(8),
              f9 = sim.renderFrame(9);
  EXPECT_EQ(cal.addFrame(f0, f0.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("no previous scan"), std::string::npos) << msg;
  ASSERT_EQ(cal.addFrame(f1, f1.stamp, &msg, &kf), FrameResult::kKeyframe) << msg;
  // The keyframe holds the de-skewed scan: points moved by up to v x 50 ms (behind the car).
  ASSERT_EQ(kf->scan.size(), f1.scan.size());
  const double moved = largestCorrection(kf->scan, f1.scan);
  const double v = (sim.worldFromLidar(0).inverse() * sim.worldFromLidar(1)).translation().norm() /
                   (f1.stamp - f0.stamp);
  std::cout << "[ deskew   ] speed " << v << " m/s, largest correction " << moved << " m, "
            << kf->seconds_deskew << " s\n";
  EXPECT_NEAR(moved, 0.05 * v, 0.1 * 0.05 * v);
  EXPECT_GT(kf->seconds_deskew, 0.0);
  // Frame 8 comes 0.7 s after frame 1: a keyframe by time, but its previous scan is too old.
  EXPECT_EQ(cal.addFrame(f8, f8.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("s old"), std::string::npos) << msg;
  EXPECT_EQ(cal.addFrame(f9, f9.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(cal.windowFill(), 2u);
}

TEST(OnlineCalibratorGenerated, WithoutTheAzimuthModelOnlyCloudsWithPointTimesAreDeskewed) {
  // ScanSweep::by_azimuth false (live.yaml): a cloud without per-point times is taken as it is,
  // without waiting for a previous scan; one with them is de-skewed by its points' own times.
  const auto drive = sweptDrive(3);
  const Simulator& sim = *drive;
  OnlineSettings s = deskewing();
  s.sweep.by_azimuth = false;
  std::string msg;
  std::shared_ptr<const Keyframe> kf;
  Frame f0 = sim.renderFrame(0), f1 = sim.renderFrame(1);
  ASSERT_FALSE(hasPointTimes(f1.scan));
  {
    OnlineCalibrator cal(sim.rig(), s);
    ASSERT_EQ(cal.addFrame(f0, f0.stamp, &msg, &kf), FrameResult::kKeyframe) << msg;
    ASSERT_EQ(kf->scan.size(), f0.scan.size());
    for (size_t i = 0; i < f0.scan.size(); i += 97) EXPECT_EQ(kf->scan[i].x, f0.scan[i].x);
    EXPECT_EQ(kf->seconds_deskew, 0.0);
  }
  // The same scans with their points' times (the sweep's azimuth model, as a driver's field).
  for (Frame* f : {&f0, &f1})
    for (LidarPoint& p : f->scan) p.time = float(sweepTime(std::atan2(p.y, p.x)));
  OnlineCalibrator cal(sim.rig(), s);
  EXPECT_EQ(cal.addFrame(f0, f0.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("no previous scan"), std::string::npos) << msg;
  ASSERT_EQ(cal.addFrame(f1, f1.stamp, &msg, &kf), FrameResult::kKeyframe) << msg;
  ASSERT_EQ(kf->scan.size(), f1.scan.size());
  EXPECT_GT(largestCorrection(kf->scan, f1.scan), 0.2);  // 8-14 m/s over up to 50 ms
  EXPECT_GT(kf->seconds_deskew, 0.0);
}

/// The loop tests' drive: 46 frames (10 keyframes 0.5 s apart), seed 4.
const tescalib_test::SharedDrive& loopDrive() { return tescalib_test::sharedUrbanDrive(4, 46); }

/// A calibrator with a 10-keyframe window, started 1 deg / 0.1 m off on `sim`, its estimate
/// published from all 46 frames of the loop drive.
std::unique_ptr<OnlineCalibrator> calibratedOnTheLoopDrive(OnlineSettings settings,
                                                           OnlineEstimate* published) {
  settings.window_size = 10;
  const tescalib_test::SharedDrive& drive = loopDrive();
  auto cal = std::make_unique<OnlineCalibrator>(perturbedRig(drive.sim(), 3, 1.0, 0.1), settings);
  std::string msg;
  EXPECT_NO_FATAL_FAILURE(addKeyframes(*cal, drive, 0, 46));  // 10 keyframes
  EXPECT_TRUE(cal->solve(&msg, published)) << msg;
  return cal;
}

TEST(OnlineCalibratorGenerated, AFewKeyframesAfterALoopDoNotReplaceAFullWindowsEstimate) {
  // After a bag's loop the window restarts, and its first 3-keyframe solve must not replace a
  // 10-keyframe estimate (rotation errors 2-3x larger): a trace-ratio gate sees only translation
  // (rotation is 0.5 % of the trace), and a few keyframes' covariance is mostly the model
  // error's floor, like a full window's.
  const tescalib_test::SharedDrive& drive = loopDrive();
  const Simulator& sim = drive.sim();
  OnlineEstimate full;
  const auto calibrator = calibratedOnTheLoopDrive(coCalibrating(), &full);
  ASSERT_FALSE(::testing::Test::HasFailure());
  OnlineCalibrator& cal = *calibrator;
  std::string msg;
  EXPECT_EQ(full.keyframes_used, 10);
  // The loop: time jumps back, then three keyframes of the drive's start again.
  Frame again = drive.frame(0);
  again.stamp = sim.stamp(45) - 20.0;
  EXPECT_EQ(cal.addFrame(again, again.stamp, &msg), FrameResult::kReset) << msg;
  // The loop's message says what happens to the published estimate.
  EXPECT_NE(msg.find("time went backwards by 20.00 s (looping bag?): window cleared; the "
                     "published estimate is kept until a solve from 10 keyframes replaces it"),
            std::string::npos)
      << msg;
  for (int i = 0; i < 15; i += 5) {
    Frame f = drive.frame(i);
    f.stamp += again.stamp + 1.0;
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  }
  EXPECT_FALSE(cal.solve(&msg)) << "a 3-keyframe estimate replaced the 10-keyframe one";
  std::cout << "[ gate     ] " << msg << "\n";
  EXPECT_NE(msg.find("from 3 keyframes, fewer than the published estimate's 10"), std::string::npos)
      << msg;
  EXPECT_EQ(cal.estimate()->keyframes_used, 10);
  // Refilled to 10 keyframes, the window's solves are published again.
  for (int i = 15; i < 50; i += 5) {
    Frame f = drive.frame(std::min(i, 45));
    f.stamp = again.stamp + 1.0 + 0.5 * i;
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
  }
  EXPECT_TRUE(cal.solve(&msg)) << msg;
  EXPECT_EQ(cal.estimate()->keyframes_used, 10);
}

TEST(OnlineCalibratorGenerated, ASolveKeptBackSaysWhetherItStillAgreesWithThePublishedOne) {
  // A solve that is not published (here: after a bag's loop, from fewer keyframes than the
  // published estimate) says how far it is from the published one in chi2; beyond
  // changed_chi2 it says the extrinsic may have changed. The same drive again agrees; the drive
  // with the LiDAR turned by 0.3 deg about its z axis (a knock on the mount) does not.
  const tescalib_test::SharedDrive& drive = loopDrive();
  const Simulator& sim = drive.sim();
  const OnlineSettings settings = coCalibrating();
  auto afterALoop = [&](double turn_deg, std::string* msg, OnlineEstimate* kept) {
    OnlineEstimate published;
    const auto calibrator = calibratedOnTheLoopDrive(settings, &published);
    OnlineCalibrator& cal = *calibrator;
    const Eigen::Matrix3f R =
        Eigen::AngleAxisf(static_cast<float>(turn_deg / kDegPerRad), Eigen::Vector3f::UnitZ())
            .toRotationMatrix();
    const double start = sim.stamp(45) - 20.0;
    for (int i = 0; i < 15; i += 5) {
      Frame f = drive.frame(i);
      f.stamp += start;
      for (LidarPoint& p : f.scan) {
        const Eigen::Vector3f q = R * Eigen::Vector3f(p.x, p.y, p.z);
        p.x = q.x(), p.y = q.y(), p.z = q.z();
      }
      const FrameResult r = cal.addFrame(f, f.stamp, msg);
      EXPECT_TRUE(r == FrameResult::kKeyframe || (i == 0 && r == FrameResult::kReset)) << *msg;
      if (r == FrameResult::kReset) {
        EXPECT_EQ(cal.addFrame(f, f.stamp, msg), FrameResult::kKeyframe);
      }
    }
    EXPECT_FALSE(cal.solve(msg));
    *kept = *cal.lastSolve();
    std::cout << "[ changed  ] LiDAR turned " << turn_deg << " deg: " << *msg << "\n";
  };
  std::string msg;
  OnlineEstimate same, turned;
  afterALoop(0.0, &msg, &same);
  EXPECT_TRUE(same.converged);
  EXPECT_NE(msg.find("chi2 (6 DoF) from the published one"), std::string::npos) << msg;
  EXPECT_LT(same.chi2_to_published, settings.changed_chi2);
  EXPECT_EQ(msg.find("may have changed"), std::string::npos) << msg;
  afterALoop(0.3, &msg, &turned);
  EXPECT_TRUE(turned.converged);
  EXPECT_GT(turned.chi2_to_published, settings.changed_chi2);
  EXPECT_NE(msg.find("the extrinsic may have changed"), std::string::npos) << msg;
}

TEST(OnlineCalibratorGenerated, AKeyframeWithoutAStereoCloudIsRejected) {
  // Right images gone black are not taken as keyframes, and the rejection says so.
  SimOptions o;
  o.frames = 1;
  o.seed = 4;
  const Simulator sim(o);
  OnlineSettings settings = coCalibrating();
  settings.image_quality.max_clipped_difference = 1;  // the image check would refuse it first
  settings.image_quality.min_contrast = 0;
  settings.image_quality.min_sharpness_ratio = 0;
  OnlineCalibrator cal(sim.rig(), settings);
  Frame f = sim.renderFrame(0);
  f.right.setTo(cv::Scalar::all(0));
  std::string msg;
  EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("its stereo cloud has only 0 points"), std::string::npos) << msg;
  f = sim.renderFrame(0);  // the same frame with its right image is a keyframe
  EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
}

TEST(OnlineCalibratorGenerated, AnInitialGuessInABodyFrameIsNamedNotCalledARingProblem) {
  // With camera_frame set to an x-forward frame (a URDF camera_link, not the optical frame) the
  // keyframes must not be refused as "no ring structure?": the message names the frame.
  SimOptions o;
  o.frames = 1;
  o.seed = 4;
  const Simulator sim(o);
  StereoRig rig = sim.rig();
  // The optical frame's T_cam_lidar seen from a body frame (x forward, y left, z up).
  Eigen::Matrix3d body_from_optical;
  body_from_optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  rig.T_cam_lidar.linear() = body_from_optical * rig.T_cam_lidar.linear();
  rig.T_cam_lidar.translation() = body_from_optical * rig.T_cam_lidar.translation();
  OnlineCalibrator cal(rig, coCalibrating());
  const Frame f = sim.renderFrame(0);
  std::string msg;
  EXPECT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("points are in the left image under the current T_cam_lidar (the initial "
                     "one until an estimate: is the camera frame the optical one"),
            std::string::npos)
      << msg;
  EXPECT_EQ(msg.find("ring"), std::string::npos) << msg;
  // The optical frame's guess gives a keyframe.
  OnlineCalibrator right(sim.rig(), coCalibrating());
  EXPECT_EQ(right.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
}

// A camera gone dark, blinded or out of focus is named, with the measured value,
// before its keyframe is built (a 1 px blur of the right image moved a generated urban window's
// LiDAR-stereo estimate by 1.6 cm). Each degraded pair is refused for its own reason, naming the
// camera; what affects both cameras alike (the sky saturated), a partly saturated image, a
// 0.5 px blur and an exposure difference (stereo clouds equalise it) are taken.
TEST(OnlineCalibratorGenerated, RejectsDarkBlindedAndBlurredImagesWithTheReason) {
  SimOptions o;
  o.frames = 10;
  o.seed = 4;
  const Simulator sim(o);
  OnlineSettings settings;
  settings.estimate_stereo = false;
  settings.keyframe_min_dt = 0.05;
  OnlineCalibrator cal(sim.rig(), settings);
  std::string msg;
  const auto gain = [](double g) { return [g](cv::Mat* m) { m->convertTo(*m, -1, g, 0); }; };
  const auto blur = [](double px) {
    return [px](cv::Mat* m) { cv::GaussianBlur(*m, *m, cv::Size(0, 0), px); };
  };
  const auto saturate_top = [](double share) {
    return [share](cv::Mat* m) {
      m->rowRange(0, static_cast<int>(share * m->rows)).setTo(cv::Scalar::all(255));
    };
  };
  const std::function<void(cv::Mat*)> none = [](cv::Mat*) {};
  struct Case {
    const char* what;
    std::function<void(cv::Mat*)> left, right;
    const char* reason;  // nullptr: taken
  };
  const std::vector<Case> cases = {
      {"right dark (15 %)", none, gain(0.15), "the right image has almost no contrast"},
      {"right blinded (x6)", none, gain(6.0), "of the right image's pixels are black or saturated"},
      {"right blurred (1.5 px)", none, blur(1.5),
       "the right image has much less fine detail than the left"},
      {"left blurred (1.5 px)", blur(1.5), none,
       "the left image has much less fine detail than the right"},
      {"right slightly blurred (0.5 px)", none, blur(0.5), nullptr},
      {"right top 30 % saturated", none, saturate_top(0.3), nullptr},
      {"both top 40 % saturated", saturate_top(0.4), saturate_top(0.4), nullptr},
      {"right exposed 2x", none, gain(2.0), nullptr},
      {"as rendered", none, none, nullptr},
  };
  std::map<std::string, size_t> points;
  std::map<std::string, bool> equalized;
  int i = 0;
  for (const Case& c : cases) {
    Frame f = sim.renderFrame(i++);
    c.left(&f.left);
    c.right(&f.right);
    ImageQuality left, right;
    pairQualityProblem(f.left, f.right, settings.image_quality, &left, &right);
    const double ratio = right.sharpness / left.sharpness;
    std::cout << "[ quality  ] " << c.what << ": contrast " << left.contrast << " / "
              << right.contrast << ", clipped " << left.clipped_fraction << " / "
              << right.clipped_fraction << ", sharpness ratio " << ratio << "\n";
    if (std::string(c.what) == "as rendered") {
      EXPECT_NEAR(ratio, 1.0, 0.05);
    }
    std::shared_ptr<const Keyframe> built;
    const FrameResult r = cal.addFrame(f, f.stamp, &msg, &built);
    if (c.reason) {
      EXPECT_EQ(r, FrameResult::kRejected) << c.what;
      EXPECT_NE(msg.find(c.reason), std::string::npos) << c.what << ": " << msg;
    } else {
      ASSERT_EQ(r, FrameResult::kKeyframe) << c.what << ": " << msg;
      ASSERT_TRUE(built);
      points[c.what] = built->stereo.points.size();
      equalized[c.what] = built->stereo.exposure_equalized;
    }
  }
  EXPECT_EQ(cal.windowFill(), 5u);
  // The 2x exposure is matched after mapping the images' grey values, and keeps about as many
  // points as the pair as rendered (StereoGenerated.ARightCameraExposedDifferently... measures
  // how few it keeps without).
  std::cout << "[ quality  ] stereo points: right exposed 2x " << points["right exposed 2x"]
            << ", as rendered " << points["as rendered"] << "\n";
  EXPECT_TRUE(equalized["right exposed 2x"]);
  EXPECT_FALSE(equalized["as rendered"]);
  EXPECT_GT(points["right exposed 2x"], 0.8 * points["as rendered"]);
  EXPECT_THROW(imageQuality(cv::Mat(10, 10, CV_16UC1, cv::Scalar(1000))), DataError);
}

TEST(OnlineCalibratorGenerated, OnceCalibratedThePublishedEstimateAveragesFreshWindows) {
  // Twenty keyframes, a solve after each, LiDAR-stereo, window 10. Once a full window's estimate
  // is published, the solves whose windows overlap the last counted one are held (as routine,
  // not as a problem) and the next counted window that agrees is published as the mean of the
  // two windows, within the end-to-end test's accuracy of the truth.
  const tescalib_test::SharedDrive& drive = tescalib_test::sharedUrbanDrive(7, 96);
  OnlineSettings settings;
  settings.estimate_stereo = false;
  OnlineCalibrator cal(perturbedRig(drive.sim(), 5, 1.0, 0.1), settings);
  std::string msg;
  int held = 0, averaged = 0, before_full = 0;
  for (int i = 0; i < 96; i += 5) {
    const Frame& f = drive.frame(i);
    ASSERT_EQ(cal.addFrame(f, f.stamp, &msg), FrameResult::kKeyframe) << msg;
    if (!cal.readyToSolve()) continue;
    OnlineEstimate published;
    if (cal.solve(&msg, &published)) {
      if (published.windows_averaged > 1) {
        ++averaged;
        const Vector6d e = poseError(published.T_cam_lidar, drive.sim().rig().T_cam_lidar);
        std::cout << "[ average  ] mean of " << published.windows_averaged << " windows at "
                  << published.stamp << " s: " << e.head<3>().norm() * kDegPerRad << " deg / "
                  << e.tail<3>().norm() * 100 << " cm\n";
        EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.2);
        EXPECT_LT(e.tail<3>().norm(), 0.03);
      } else {
        before_full += averaged == 0;
      }
    } else if (cal.lastSolve() && cal.lastSolve()->held_between_windows) {
      ++held;
      EXPECT_NE(msg.find("held: the published estimate is the mean of"), std::string::npos) << msg;
    }
  }
  std::cout << "[ average  ] " << before_full << " published before averaging, " << held
            << " held, " << averaged << " averaged\n";
  EXPECT_GE(before_full, 1);
  EXPECT_GE(held, 3);
  EXPECT_GE(averaged, 1);
}
