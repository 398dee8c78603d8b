// Bad input to the core's entry points, found by fuzzing: unguarded, each would crash (a PCL
// assertion, a segfault in Ceres' covariance, std::terminate from SGBM) or let an OpenCV
// exception escape. Each gives a result with converged = false and a message, or a DataError.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"
#include "tescalib/core/lidar/lidar_mesh.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/photometric_solver.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {
namespace {

/// Three keyframes of a short generated drive, built with the true extrinsics.
struct SmallWindow {
  std::unique_ptr<Simulator> sim;
  std::vector<Keyframe> keyframes;
  std::vector<const Keyframe*> window;
  std::vector<Keyframe*> mutable_window;
  SmallWindow() {
    SimOptions o;
    o.frames = 11;
    o.seed = 4;
    sim = std::make_unique<Simulator>(o);
    for (int i : {0, 5, 10})
      keyframes.push_back(makeKeyframe(sim->renderFrame(i), sim->rig(), sim->rig().T_cam_lidar,
                                       sim->rig().T_right_left));
    for (auto& k : keyframes) window.push_back(&k), mutable_window.push_back(&k);
  }
};

Eigen::Isometry3d withNaN(Eigen::Isometry3d T) {
  T.translation().x() = std::nan("");
  return T;
}

TEST(Robustness, SolversRefuseStartsThatAreNotRigidTransforms) {
  const SmallWindow w;
  const StereoRig& rig = w.sim->rig();
  const LidarStereoResult ls =
      solveLidarStereoSearch(w.window, withNaN(rig.T_cam_lidar), LidarStereoSettings{});
  EXPECT_FALSE(ls.converged);
  EXPECT_NE(ls.message.find("not a rigid transform"), std::string::npos) << ls.message;

  Eigen::Isometry3d scaled = rig.T_right_left;
  scaled.linear() *= 2.0;  // determinant 8: came back "converged" with it
  for (const Eigen::Isometry3d& T :
       {withNaN(rig.T_right_left), scaled, Eigen::Isometry3d(Eigen::Isometry3d::Identity())}) {
    const PhotometricResult ph = solvePhotometric(w.window, rig, rig.T_cam_lidar, T);
    EXPECT_FALSE(ph.converged);
    EXPECT_NE(ph.message.find("initial guess"), std::string::npos) << ph.message;
  }
  SmallWindow co;
  const CoCalibrationResult r = coCalibrate(co.mutable_window, rig, rig.T_cam_lidar,
                                            Eigen::Isometry3d::Identity());  // no baseline
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("no baseline"), std::string::npos) << r.message;
}

TEST(Robustness, ThePhotometricSolverChecksTheRigAgainstTheImages) {
  const SmallWindow w;
  StereoRig rig = w.sim->rig();
  rig.left.width = 300;  // the mesh depth would be rendered smaller than the images
  const PhotometricResult r = solvePhotometric(w.window, rig, rig.T_cam_lidar, rig.T_right_left);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("not of the rig's size"), std::string::npos) << r.message;
  // No covariance was computed: the identity it holds is a placeholder, not an uncertainty.
  EXPECT_FALSE(r.covariance_known);
  PhotometricSettings s;
  s.cell_size = 0;  // looped forever
  const StereoRig& good = w.sim->rig();
  const PhotometricResult rc =
      solvePhotometric(w.window, good, good.T_cam_lidar, good.T_right_left, s);
  EXPECT_FALSE(rc.converged);
  EXPECT_NE(rc.message.find("cell_size"), std::string::npos) << rc.message;
}

TEST(Robustness, SolversRefuseSettingsTheyCannotRun) {
  // Each is named as a setting, not reported as a scene problem or as converged from the true
  // start.
  const SmallWindow w;
  const StereoRig& rig = w.sim->rig();
  for (int bad : {0, 1}) {
    LidarStereoSettings ls;
    (bad == 0 ? ls.threads : ls.ceres_iterations) = -5;
    const LidarStereoResult r = solveLidarStereo(w.window, rig.T_cam_lidar, ls);
    EXPECT_FALSE(r.converged);
    EXPECT_NE(r.message.find("must be at least 1"), std::string::npos) << r.message;
    PhotometricSettings ps;
    (bad == 0 ? ps.threads : ps.iterations_per_level) = -1;
    const PhotometricResult p =
        solvePhotometric(w.window, rig, rig.T_cam_lidar, rig.T_right_left, ps);
    EXPECT_FALSE(p.converged);
    EXPECT_NE(p.message.find("must be at least 1"), std::string::npos) << p.message;
  }
  const LidarStereoResult good = solveLidarStereo(w.window, rig.T_cam_lidar, {});
  EXPECT_EQ(good.message.find("must be at least 1"), std::string::npos) << good.message;
}

TEST(Robustness, ThePhotometricSolverSaysWhatItCannotConstrain) {
  // Each of these must be refused with a message, neither accepted nor aborting the process.
  SmallWindow w;
  const StereoRig& rig = w.sim->rig();
  // A covered right camera (uniform image): the pose's Jacobian is zero. Ceres' truncated
  // pseudo-inverse gave those directions variance 0, "known", every axis trusted.
  {
    SmallWindow covered;
    for (Keyframe& kf : covered.keyframes) kf.right_gray.setTo(90);
    const PhotometricResult r =
        solvePhotometric(covered.window, rig, rig.T_cam_lidar, rig.T_right_left);
    EXPECT_FALSE(r.converged);
    EXPECT_FALSE(r.covariance_known) << r.message;
    for (bool o : r.observable) EXPECT_FALSE(o);
    EXPECT_TRUE(r.weak_directions.empty());
  }
  // min_keypoints 0 let a level with no key point reach Ceres' covariance (a glog CHECK abort).
  PhotometricSettings none;
  none.min_keypoints = 0;
  const PhotometricResult r0 =
      solvePhotometric(w.window, rig, rig.T_cam_lidar, rig.T_right_left, none);
  EXPECT_FALSE(r0.converged);
  EXPECT_NE(r0.message.find("min_keypoints must be at least 1"), std::string::npos) << r0.message;
  // A right image of another size than the rig's right camera was read with the wrong layout.
  SmallWindow small;
  cv::resize(small.keyframes[1].right_gray, small.keyframes[1].right_gray, cv::Size(), 0.5, 0.5);
  const PhotometricResult rs =
      solvePhotometric(small.window, rig, rig.T_cam_lidar, rig.T_right_left);
  EXPECT_FALSE(rs.converged);
  EXPECT_NE(rs.message.find("not of the rig's sizes"), std::string::npos) << rs.message;
  // The key point cap is exact (an accumulated floating-point step kept one more now and then).
  const MeshDepth md = renderMeshDepth(w.keyframes[0].mesh, rig.T_cam_lidar, rig.left);
  PhotometricSettings all;
  all.max_keypoints_per_keyframe = 1 << 20;
  const size_t n = selectKeyPoints(w.keyframes[0], md, all).size();
  ASSERT_GT(n, 400u);
  for (int cap : {6, 13, 97, 250, static_cast<int>(n) - 1}) {
    PhotometricSettings s;
    s.max_keypoints_per_keyframe = cap;
    EXPECT_EQ(selectKeyPoints(w.keyframes[0], md, s).size(), static_cast<size_t>(cap));
  }
}

TEST(Robustness, ReTriangulatingWithTheSameExtrinsicKeepsEveryMatch) {
  // The bilinear lookup must not want all four neighbours matched at a pixel's own position
  // (weight 0 for the others), or each matched region loses its right and bottom edge; and a NaN
  // extrinsic must not reach cv::stereoRectify's assertion.
  const SmallWindow w;
  const Keyframe& kf = w.keyframes[0];
  const StereoRig& rig = w.sim->rig();
  const StereoCloud again = retriangulateStereoCloud(kf.stereo, rig, kf.T_right_left_used);
  const cv::Mat valid_before = kf.stereo.disparity == kf.stereo.disparity;  // not NaN
  const cv::Mat valid_after = again.disparity == again.disparity;
  EXPECT_GT(cv::countNonZero(valid_before), 10000);
  EXPECT_EQ(cv::countNonZero(valid_after), cv::countNonZero(valid_before));
  // The same pixels, with the same disparities (the rectification is unchanged: no shift, no
  // sign error).
  EXPECT_EQ(cv::countNonZero(valid_before != valid_after), 0);
  cv::Mat diff;
  cv::absdiff(again.disparity, kf.stereo.disparity, diff);
  double max_diff = 0;
  cv::minMaxLoc(diff, nullptr, &max_diff, nullptr, nullptr, valid_before);
  EXPECT_LT(max_diff, 1e-3);
  double d = 0;
  EXPECT_FALSE(kf.stereo.disparityAt(std::nan(""), 10.0, &d));
  EXPECT_THROW(retriangulateStereoCloud(kf.stereo, rig, withNaN(kf.T_right_left_used)), DataError);
}

TEST(Robustness, TheLidarDisparityCheckStaysInsideTheRightImage) {
  // A point whose disparity is under the search's shift, near the right edge, must not read past
  // the right image's last column (past the buffer on the last rows).
  StereoRig rig;
  rig.left = {100, 100, 32, 16, 64, 32};
  rig.right = rig.left;
  rig.T_right_left.translation() = Eigen::Vector3d(-0.1, 0, 0);  // f b = 10 px m
  cv::Mat img(32, 64, CV_8UC1);
  for (int u = 0; u < 64; ++u) img.col(u).setTo(u % 4 < 2 ? 0 : 255);  // texture everywhere
  auto pointAt = [](double u, double v, double z) {
    LidarPoint p;
    p.x = float((u - 32) * z / 100), p.y = float((v - 16) * z / 100), p.z = float(z);
    return p;
  };
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  // Disparity 1 px at 10 m: u = 61 searches columns up to 61 - 1 + 8 + 2 = 70 of 64.
  EXPECT_EQ(lidarDisparityAgreement({pointAt(61, 29, 10.0)}, img, img, rig, I).points, 0);
  EXPECT_EQ(lidarDisparityAgreement({pointAt(32, 16, 10.0)}, img, img, rig, I).points, 1);
  EXPECT_THROW(lidarDisparityAgreement({}, img, img(cv::Rect(0, 0, 32, 32)), rig, I), DataError);
}

TEST(Robustness, TheLidarMeshRefusesRingsAndSettingsItCannotGrid) {
  SimOptions o;
  o.frames = 1;
  const Simulator sim(o);
  LidarScan scan = sim.renderScan(0);
  EXPECT_GT(buildLidarMesh(scan).faces.size(), 1000u);
  LidarMeshSettings s;
  s.smooth_cols = 1 << 30;  // overflowed the fit's loop
  EXPECT_THROW(buildLidarMesh(scan, s), DataError);
  s = LidarMeshSettings{};
  s.azimuth_bins = 0;
  EXPECT_THROW(buildLidarMesh(scan, s), DataError);
  scan.back().ring = 65535;  // a 65536-row range image, about 1 GB
  try {
    buildLidarMesh(scan);
    ADD_FAILURE() << "a ring of 65535 was gridded";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("65535"), std::string::npos) << e.what();
  }
}

TEST(Robustness, StereoCloudsRefuseWhatSgbmCannotUse) {
  SimOptions o;
  o.frames = 1;
  const Simulator sim(o);
  const StereoRig& rig = sim.rig();
  const cv::Mat tiny(20, 60, CV_8UC3, cv::Scalar(100, 100, 100));  // std::terminate in SGBM
  EXPECT_THROW(computeStereoCloud(tiny, tiny, rig, rig.T_right_left), DataError);
  const Frame f = sim.renderFrame(0);
  cv::Mat grey;
  cv::extractChannel(f.left, grey, 0);
  EXPECT_THROW(computeStereoCloud(grey, grey, rig, rig.T_right_left), DataError);
  try {
    computeStereoCloud(f.left, f.right, rig, Eigen::Isometry3d::Identity());
    ADD_FAILURE() << "a pair without a baseline was matched";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no baseline"), std::string::npos) << e.what();
  }
  StereoSettings s;
  s.sample_step = 0;  // looped forever
  EXPECT_THROW(computeStereoCloud(f.left, f.right, rig, rig.T_right_left, s), DataError);
}

TEST(Robustness, TheOnlineCalibratorRejectsWhatItCannotUseAndGoesOn) {
  SimOptions o;
  o.frames = 3;
  o.seed = 4;
  const Simulator sim(o);
  OnlineSettings s;
  s.estimate_stereo = false;
  s.min_keyframes = 0;  // solve() on an empty window crashed
  s.window_size = -1;   // the first keyframe crashed
  OnlineCalibrator cal(sim.rig(), s);
  std::string msg;
  EXPECT_FALSE(cal.solve(&msg));
  Frame f0 = sim.renderFrame(0), f1 = sim.renderFrame(1);
  Frame nan_stamp = f0;
  nan_stamp.stamp = std::nan("");
  EXPECT_EQ(cal.addFrame(nan_stamp, nan_stamp.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("not finite"), std::string::npos) << msg;
  // A frame selected by time and then not taken (too few mesh faces) leaves the next frame,
  // 0.1 s later, free to be the keyframe (it was "too close" to the rejected one).
  Frame sparse = f0;
  sparse.scan.resize(10);
  EXPECT_EQ(cal.addFrame(sparse, sparse.stamp, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("mesh faces"), std::string::npos) << msg;
  EXPECT_EQ(cal.addFrame(f1, f1.stamp, &msg), FrameResult::kKeyframe) << msg;
  EXPECT_EQ(cal.windowFill(), 1u);
}

}  // namespace
}  // namespace tescalib
