// Co-calibration on a generated urban window (exact ground truth, rendered in memory): from the
// benchmark's start (LiDAR 3 deg / 0.3 m, stereo 1 deg / 0.1 m off) the alternation recovers both
// extrinsics within the success tolerances and says it converged; a LiDAR-stereo estimate that
// runs away from the initial guess is not taken, and rounds that would repeat such a runaway
// stop, while the stereo pair from feature matches converges from there; the LiDAR estimate's
// sensitivity to the stereo pair; the re-rectification test.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "shared_drive.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/solvers/joint_calibration.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/uncertainty/trust.h"

using namespace tescalib;

namespace {

struct GeneratedWindow {
  StereoRig rig;
  std::vector<Keyframe> keyframes;
  std::vector<Keyframe*> window() {
    std::vector<Keyframe*> w;
    for (auto& kf : keyframes) w.push_back(&kf);
    return w;
  }
};

/// The rig of the generated urban drive of seed 1 and a LiDAR start 3 deg / 0.3 m off it (the
/// benchmark's), drawn from `rng`.
struct CoStart {
  StereoRig truth;
  Eigen::Isometry3d T_cl_init;
};
CoStart lidarStart(std::mt19937_64& rng) {
  SimOptions o;
  o.seed = 1;
  CoStart c{Simulator(o).rig(), Eigen::Isometry3d::Identity()};
  c.T_cl_init = perturb(c.truth.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  return c;
}

/// `n` keyframes 0.5 s apart of a generated urban drive; meshes view-filtered with `T_cl_guess`,
/// no stereo clouds yet (co-calibration computes them).
/// `drive_frames` > 0: the keyframes are the first of a drive that long (its scene depends on
/// the length), as `tescalib_eval` sees the drive `tescalib_simulate --frames drive_frames` wrote.
/// `sampled_faces`: LidarMeshSettings::sampled_faces of the meshes (0: every face's normal).
GeneratedWindow generatedWindow(int n, uint64_t seed, const Eigen::Isometry3d* T_cl_guess,
                                int drive_frames = 0,
                                int sampled_faces = LidarMeshSettings().sampled_faces) {
  const tescalib_test::SharedDrive& drive =
      tescalib_test::sharedUrbanDrive(seed, std::max(5 * (n - 1) + 1, drive_frames));
  GeneratedWindow w;
  w.rig = drive.sim().rig();
  for (int i = 0; i < 5 * (n - 1) + 1; i += 5) {
    const Frame& f = drive.frame(i);
    KeyframeSettings ks;
    ks.mesh.sampled_faces = sampled_faces;
    Keyframe kf = makeKeyframe(f, w.rig, T_cl_guess ? *T_cl_guess : w.rig.T_cam_lidar,
                               w.rig.T_right_left, ks);
    kf.stereo = StereoCloud{};  // co-calibration must compute its own
    w.keyframes.push_back(std::move(kf));
  }
  return w;
}

/// A co-calibration case: the LiDAR start of lidarStart (rng seed 3), then a stereo start
/// `stereo_rot_deg` / `stereo_trans_m` off the truth, and `n` keyframes of drive 1 view-filtered
/// with the LiDAR start.
struct CoCase {
  StereoRig truth;
  Eigen::Isometry3d T_cl_init, T_rl_init;
  GeneratedWindow w;
};
CoCase coCase(int n, double stereo_rot_deg, double stereo_trans_m,
              int sampled_faces = LidarMeshSettings().sampled_faces) {
  std::mt19937_64 rng(3);
  CoCase c;
  const CoStart start = lidarStart(rng);
  c.truth = start.truth;
  c.T_cl_init = start.T_cl_init;
  c.T_rl_init = perturb(c.truth.T_right_left,
                        randomPerturbation(stereo_rot_deg / kDegPerRad, stereo_trans_m, rng));
  c.w = generatedWindow(n, 1, &c.T_cl_init, 0, sampled_faces);
  return c;
}

/// The LiDAR start of lidarStart (rng seed 3) and the hardest stereo start of the benchmark's kind:
/// 1 deg off and the baseline 10 cm short (the benchmark's starts are 5-10 cm short); 10 keyframes
/// of drive 1 (the node's window; its first 8 leave the LiDAR's depth axis at its trust limit,
/// 0.95-1.08x with either SGBM setting).
CoCase shortBaselineCase() {
  std::mt19937_64 rng(3);
  CoCase c;
  const CoStart start = lidarStart(rng);
  c.truth = start.truth;
  c.T_cl_init = start.T_cl_init;
  Vector6d stereo_delta = randomPerturbation(1.0 / kDegPerRad, 0.1, rng);
  stereo_delta.tail<3>() = Eigen::Vector3d(0.1, 0, 0);
  c.T_rl_init = perturb(c.truth.T_right_left, stereo_delta);
  c.w = generatedWindow(10, 1, &c.T_cl_init);
  return c;
}

/// Trial 0 of `tescalib_eval --mode co --seed eval_seed --init-rot-deg rot_deg --init-trans-m
/// trans_m --init-stereo-rot-deg 1 --init-stereo-trans-m 0.1 --window 10` on the generated urban
/// drive of seed `drive` (100 frames): its starts and window 0.
CoCase evalCoTrial(uint64_t drive, uint64_t eval_seed, double rot_deg, double trans_m) {
  std::mt19937_64 rng(eval_seed * 1000003ULL);
  const Vector6d lidar_delta = randomPerturbation(rot_deg / kDegPerRad, trans_m, rng);
  const Vector6d stereo_delta = randomPerturbation(1.0 / kDegPerRad, 0.1, rng);
  SimOptions o;
  o.seed = drive;
  CoCase c;
  c.truth = Simulator(o).rig();
  c.T_cl_init = perturb(c.truth.T_cam_lidar, lidar_delta);
  c.T_rl_init = perturb(c.truth.T_right_left, stereo_delta);
  c.w = generatedWindow(10, drive, &c.T_cl_init, 100);
  return c;
}

// A converged left-right result 0.54 m wide, sigmas 0.002 deg / 0.3 mm per axis given the
// LiDAR, whose tz moves 0.3 per unit of the LiDAR's tz.
PhotometricResult trustedPair() {
  PhotometricResult stereo;
  stereo.T_right_left.translation() = Eigen::Vector3d(-0.54, 0, 0);
  stereo.covariance = Matrix6d::Zero();
  addAxisVariances(&stereo.covariance, {0.002, 0.002, 0.002}, {0.0003, 0.0003, 0.0003});
  stereo.converged = true;
  std::fill(stereo.observable, stereo.observable + 6, true);
  stereo.lidar_sensitivity(5, 5) = 0.3;
  return stereo;
}

}  // namespace

TEST(CoCalibration, RerectificationOnlyWhenTheRotationOrDirectionChanges) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  a.translation() = Eigen::Vector3d(-0.54, 0, 0);
  Eigen::Isometry3d longer = a;
  longer.translation() *= 1.05;  // the baseline length is the stereo scale's business
  EXPECT_FALSE(needsRerectification(a, longer, 0.005));
  Vector6d d = Vector6d::Zero();
  d[1] = 0.01 / kDegPerRad;  // 0.01 deg about y
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005));
  d.setZero();
  d[5] = 0.54 * std::tan(0.01 / kDegPerRad);  // baseline direction 0.01 deg towards z
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005));
  d[5] = 0.54 * std::tan(0.002 / kDegPerRad);
  EXPECT_FALSE(needsRerectification(a, perturb(a, d), 0.005));
  // A separate, looser direction tolerance (online warm updates): 0.01 deg of direction passes,
  // 0.01 deg of rotation does not.
  d[5] = 0.54 * std::tan(0.01 / kDegPerRad);
  EXPECT_FALSE(needsRerectification(a, perturb(a, d), 0.005, 0.05));
  d[5] = 0.54 * std::tan(0.06 / kDegPerRad);
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005, 0.05));
  d.setZero();
  d[1] = 0.01 / kDegPerRad;
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005, 0.05));
  // A separate yaw tolerance (the LiDAR-stereo solve models the yaw): 0.01 deg of yaw passes,
  // 0.04 deg does not, and 0.01 deg about x still does not pass.
  EXPECT_FALSE(needsRerectification(a, perturb(a, d), 0.005, 0.05, 0.03));
  d[1] = 0.04 / kDegPerRad;
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005, 0.05, 0.03));
  d.setZero();
  d[0] = 0.01 / kDegPerRad;
  EXPECT_TRUE(needsRerectification(a, perturb(a, d), 0.005, 0.05, 0.03));
}

// The left-right covariance of a co-calibration carries the LiDAR's uncertainty, and so do the
// left-right trust flags: a LiDAR extrinsic loose along its optical axis makes the stereo
// translation along z untrustworthy, which the photometric solve alone (LiDAR taken as exact)
// could not see. The length component of the sensitivity is not the photometric solve's (the
// stereo scale gives the length) and must not count.
TEST(CoCalibration, StereoTrustFlagsIncludeTheLidarUncertainty) {
  CoCalibrationSettings s;
  PhotometricResult stereo = trustedPair();
  stereo.lidar_sensitivity(3, 5) = 0.5;  // baseline length per LiDAR tz: the scale's business
  LidarStereoResult lidar;
  lidar.stereo_scale_variance = 0.001 * 0.001;
  lidar.covariance = Matrix6d::Zero();
  addAxisVariances(&lidar.covariance, {0.01, 0.01, 0.01}, {0.002, 0.002, 0.01});

  PhotometricResult tight = stereo;  // LiDAR tz sigma 1 cm: stereo tz sigma 3 mm
  EXPECT_TRUE(coStereoCovariance(lidar, s, &tight));
  EXPECT_TRUE(tight.converged);
  const double mm2 = 1e-6;
  const double model_x = s.model_sigma_stereo_trans_m[0] * 1e3;  // mm
  const double model_z = s.model_sigma_stereo_trans_m[2] * 1e3;
  EXPECT_NEAR(tight.covariance(5, 5), (0.09 + 9.0 + model_z * model_z) * mm2, 1e-9);
  // Along the baseline: the statistical part, the scale's variance times |t|^2 (0.54 mm) and
  // the model error, not the 5 mm the sensitivity's length component would add.
  EXPECT_NEAR(tight.covariance(3, 3), (0.09 + 0.54 * 0.54 + model_x * model_x) * mm2, 1e-9);
  // coCalibrate's form: the LiDAR covariance given the pair instead of lidar.covariance.
  PhotometricResult given = stereo;
  Matrix6d lidar_given = Matrix6d::Zero();
  addAxisVariances(&lidar_given, {0.01, 0.01, 0.01}, {0.002, 0.002, 0.02});  // tz sigma 2 cm
  EXPECT_TRUE(coStereoCovariance(lidar, s, &given, lidar_given));
  EXPECT_NEAR(given.covariance(5, 5), (0.09 + 36.0 + model_z * model_z) * mm2, 1e-9);

  addAxisVariances(&lidar.covariance, {0, 0, 0}, {0, 0, 0.05});  // LiDAR tz sigma 5 cm
  PhotometricResult loose = stereo;                              // stereo tz sigma 1.5 cm
  EXPECT_FALSE(coStereoCovariance(lidar, s, &loose));
  EXPECT_FALSE(loose.converged);
  EXPECT_FALSE(loose.observable[5]);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(loose.observable[i]) << "axis " << i;
  EXPECT_NE(loose.message.find("LiDAR"), std::string::npos) << loose.message;
}

// The pair's covariance at the alternation's fixed point: its tz moves the LiDAR's tz by 0.5 (S),
// which moves its tz by 0.3 again (L), a loop of 0.15; the pair's tz variance is then the
// variance without the loop over (1 - 0.15)^2. The scale's model error widens the length by
// B sigma and moves the LiDAR along the valley by the window's scale sensitivity, both for the
// pair's f B (half the reference's: twice the sigma).
TEST(CoCalibration, ThePairsCovarianceHoldsTheLoopAndTheScalesModelError) {
  CoCalibrationSettings s;
  PhotometricResult stereo = trustedPair();
  LidarStereoResult lidar;
  Matrix6d lidar_given = Matrix6d::Zero();
  addAxisVariances(&lidar_given, {0.01, 0.01, 0.01}, {0.002, 0.002, 0.01});
  Matrix6d S = Matrix6d::Zero();
  S(5, 5) = 0.5;
  PhotometricResult open = stereo, loop = stereo;
  EXPECT_TRUE(coStereoCovariance(lidar, s, &open, lidar_given));
  EXPECT_TRUE(coStereoCovariance(lidar, s, &loop, lidar_given, &S));
  const double model_z2 = std::pow(s.model_sigma_stereo_trans_m[2], 2);
  const double without = (0.09 + 9.0) * 1e-6;  // 0.3 mm, and 0.3 x the LiDAR's 1 cm
  EXPECT_NEAR(open.covariance(5, 5), without + model_z2, 1e-12);
  EXPECT_NEAR(loop.covariance(5, 5), without / (0.85 * 0.85) + model_z2, 1e-12);
  EXPECT_NEAR(loop.covariance(4, 4), open.covariance(4, 4), 1e-15);  // no loop along y

  LidarStereoSettings ls;
  LidarStereoResult scaled;
  scaled.covariance_known = true;
  scaled.covariance = Matrix6d::Zero();
  scaled.stereo_scale_variance = 1e-6;
  scaled.focal_baseline_px_m = ls.model_floor_focal_baseline_px_m / 2;
  scaled.stereo_scale_sensitivity << 0, 0, 0, 0.1, 0, -2.0;  // m per unit of scale
  addScaleFloor(ls, s, &scaled);
  const double sigma = 2 * s.model_sigma_stereo_scale;
  EXPECT_NEAR(scaled.stereo_scale_variance, 1e-6 + sigma * sigma, 1e-15);
  EXPECT_NEAR(scaled.covariance(5, 5), 4.0 * sigma * sigma, 1e-15);
  EXPECT_NEAR(scaled.covariance(3, 5), -0.2 * sigma * sigma, 1e-15);
  EXPECT_EQ(scaled.covariance(0, 0), 0.0);
  LidarStereoResult unknown;  // a placeholder covariance is left alone
  addScaleFloor(ls, s, &unknown);
  EXPECT_EQ(unknown.stereo_scale_variance, 0.0);
  EXPECT_TRUE(unknown.covariance.isIdentity());
}

TEST(CoCalibration, RecoversBothExtrinsicsOnAGeneratedUrbanWindow) {
  CoCase c = shortBaselineCase();
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  const std::vector<Keyframe*> window = c.w.window();
  const CoCalibrationResult r = coCalibrate(window, w.rig, T_cl_init, T_rl_init);
  const Vector6d el = poseError(r.lidar.T_cam_lidar, truth.T_cam_lidar);
  const Vector6d es = poseError(r.stereo.T_right_left, truth.T_right_left);
  std::cout << "[ co       ] " << r.rounds << " rounds, " << r.extrapolations << " extrapolations, "
            << r.rectifications << " rectifications, " << r.seconds << " s; LiDAR "
            << el.head<3>().norm() * kDegPerRad << " deg " << el.tail<3>().norm() * 100
            << " cm; stereo " << es.head<3>().norm() * kDegPerRad << " deg "
            << es.tail<3>().norm() * 1000 << " mm; " << r.message << "\n";
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_TRUE(r.stable);
  // With the clouds' yaw modelled the alternation contracts fast (5 rounds here; 15 without).
  EXPECT_LE(r.rounds, 10);
  // The success tolerances for both extrinsics, tighter per axis.
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
  EXPECT_LT(es.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(es.tail<3>().norm(), 0.03);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(std::fabs(el[i]) * kDegPerRad, 0.1) << "LiDAR rotation axis " << i;
    EXPECT_LT(std::fabs(el[3 + i]), 0.02) << "LiDAR translation axis " << i;
    EXPECT_LT(std::fabs(es[i]) * kDegPerRad, 0.03) << "stereo rotation axis " << i;
    EXPECT_LT(std::fabs(es[3 + i]), 0.005) << "stereo translation axis " << i;
  }
  // The covariances carry the co-calibration model error on top of each solve's own, and the
  // error stays within 3 sigma of them on every axis.
  const CoCalibrationSettings s;
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(r.lidar.covariance(3 + i, 3 + i), std::pow(s.model_sigma_lidar_trans_m[i], 2));
    EXPECT_GE(r.stereo.covariance(i, i), std::pow(s.model_sigma_stereo_rot_deg[i] / kDegPerRad, 2));
  }
  // The baseline length is the LiDAR-stereo solve's stereo scale: its variance is in the stereo
  // covariance along the baseline (on top of the per-axis model error).
  EXPECT_GT(r.lidar.stereo_scale_variance, 0.0);
  EXPECT_LT(std::sqrt(r.lidar.stereo_scale_variance), 0.01);
  const Eigen::Vector3d t = r.stereo.T_right_left.translation();
  EXPECT_GE(t.dot(r.stereo.covariance.bottomRightCorner<3, 3>() * t) / t.squaredNorm(),
            r.lidar.stereo_scale_variance * t.squaredNorm() +
                std::pow(s.model_sigma_stereo_trans_m[0], 2) * 0.99);
  for (int i = 0; i < 6; ++i) {
    EXPECT_LT(std::fabs(el[i]), 3 * std::sqrt(r.lidar.covariance(i, i))) << "LiDAR axis " << i;
    EXPECT_LT(std::fabs(es[i]), 3 * std::sqrt(r.stereo.covariance(i, i))) << "stereo axis " << i;
  }
}

// The joint problem (--mode joint) from the same start: both extrinsics within the success
// tolerances, and covariances that hold the joint model error and the error within 3 sigma.
TEST(JointCalibration, RecoversBothExtrinsicsOnAGeneratedUrbanWindow) {
  CoCase c = coCase(10, 1.0, 0.1, 0);  // the joint problem needs every face's normal
  const JointCalibrationSettings js;
  const CoCalibrationResult r = jointCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init, js);
  const Vector6d el = poseError(r.lidar.T_cam_lidar, c.truth.T_cam_lidar);
  const Vector6d es = poseError(r.stereo.T_right_left, c.truth.T_right_left);
  std::cout << "[ joint    ] " << r.rounds << " outer iterations, " << r.seconds << " s; LiDAR "
            << el.head<3>().norm() * kDegPerRad << " deg " << el.tail<3>().norm() * 100
            << " cm; stereo " << es.head<3>().norm() * kDegPerRad << " deg "
            << es.tail<3>().norm() * 1000 << " mm; " << r.message << "\n";
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
  EXPECT_LT(es.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(es.tail<3>().norm(), 0.03);
  // Both model errors are in the covariances (the joint one alone is 0 along some axes).
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(r.lidar.covariance(3 + i, 3 + i),
              std::pow(js.model_sigma_lidar_trans_m[i], 2) +
                  std::pow(js.co_model_sigma_lidar_trans_m[i], 2));
    EXPECT_GE(r.stereo.covariance(3 + i, 3 + i),
              std::pow(js.model_sigma_stereo_trans_m[i], 2) +
                  std::pow(js.co_model_sigma_stereo_trans_m[i], 2));
  }
  EXPECT_EQ(r.yaw_handovers, 0);
  EXPECT_TRUE(r.lidar_covariance_given_stereo.isApprox(r.lidar.covariance));
  for (int i = 0; i < 6; ++i) {
    EXPECT_LT(std::fabs(el[i]), 3 * std::sqrt(r.lidar.covariance(i, i))) << "LiDAR axis " << i;
    EXPECT_LT(std::fabs(es[i]), 3 * std::sqrt(r.stereo.covariance(i, i))) << "stereo axis " << i;
  }
}

// The joint estimate is declared converged only when its covariance solves converged at it
// (otherwise a real KITTI start can be declared converged 4.75 cm off with a LiDAR-stereo
// covariance solve that has not settled; that case needs real data). Here that solve does not
// converge because no window meets a trust limit of 0.01 mm, and the result says that
// the covariance solve at the joint estimate is what failed (the initial rounds' LiDAR solves
// fail the same way, which the joint problem does not need).
TEST(JointCalibration, ACovarianceSolveThatDidNotConvergeIsNotAConvergedResult) {
  CoCase c = coCase(8, 1.0, 0.1, 0);
  JointCalibrationSettings js;
  js.co.lidar.max_sigma_trans_m = 1e-5;
  const CoCalibrationResult r = jointCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init, js);
  EXPECT_FALSE(r.converged);
  EXPECT_FALSE(r.lidar.converged);
  EXPECT_NE(r.message.find("the LiDAR-stereo solve at the joint estimate did not converge: the "
                           "window does not constrain every axis"),
            std::string::npos)
      << r.message;
  // The joint estimate itself is the one the default settings reach.
  EXPECT_TRUE(r.stable);
  const Vector6d el = poseError(r.lidar.T_cam_lidar, c.truth.T_cam_lidar);
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
}

// The wiring of secondOpinion into jointCalibrate (its initial rounds leave it out; the joint
// estimate gets it at the end): asked always and always disagreeing (a negative tolerance), a
// window the joint problem otherwise converges on (the test above) is reported not converged
// with the second opinion's reason; the joint estimate is kept.
TEST(JointCalibration, AskedForASecondOpinionThatDisagreesTheResultIsNotConverged) {
  CoCase c = coCase(10, 1.0, 0.1, 0);
  JointCalibrationSettings js;
  js.co.confirm_beyond_deg = 0, js.co.confirm_beyond_m = 0;
  js.co.confirm_disagree_deg = -1, js.co.confirm_disagree_m = -1;
  const CoCalibrationResult r = jointCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init, js);
  EXPECT_TRUE(r.stable);
  EXPECT_FALSE(r.converged);
  EXPECT_FALSE(r.lidar.converged);
  EXPECT_NE(r.message.find("two minima"), std::string::npos) << r.message;
  const Vector6d el = poseError(r.lidar.T_cam_lidar, c.truth.T_cam_lidar);
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
}

// Meshes that fit only the solvers' sample of normals are refused with a message, and the result
// keeps the initial guesses.
TEST(JointCalibration, RefusesMeshesWithOnlyTheSampleFitted) {
  CoCase c = coCase(2, 1.0, 0.1);
  ASSERT_LT(c.w.keyframes[0].mesh.sample.size(), c.w.keyframes[0].mesh.faces.size());
  const CoCalibrationResult r = jointCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("sampled_faces = 0"), std::string::npos) << r.message;
  EXPECT_LT(poseError(r.lidar.T_cam_lidar, c.T_cl_init).norm(), 1e-12);
  EXPECT_LT(poseError(r.stereo.T_right_left, c.T_rl_init).norm(), 1e-12);
}

// A cancel raised before the solve (a node shutting down; LidarStereoSettings::cancel, which the
// alternation and the joint problem honour too): nothing runs, the initial guesses come back
// unconverged and the message says why (the online test passes whether or not the solver looks
// at the flag).
TEST(CoCalibration, ACancelledAlternationOrJointSolveRunsNoRound) {
  CoCase c = coCase(2, 1.0, 0.1, 0);
  std::atomic<bool> cancel{true};
  JointCalibrationSettings js;
  js.co.lidar.cancel = &cancel;
  const CoCalibrationResult co =
      coCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init, js.co);
  const CoCalibrationResult joint =
      jointCalibrate(c.w.window(), c.w.rig, c.T_cl_init, c.T_rl_init, js);
  EXPECT_EQ(co.features.matches, 0);  // not even the feature matching ran
  for (const CoCalibrationResult* r : {&co, &joint}) {
    SCOPED_TRACE(r == &co ? "alternation" : "joint");
    EXPECT_FALSE(r->converged);
    EXPECT_FALSE(r->lidar.converged);
    EXPECT_FALSE(r->stereo.converged);
    EXPECT_EQ(r->message, "cancelled");
    EXPECT_EQ(r->rounds, 0);
    EXPECT_LT(poseError(r->lidar.T_cam_lidar, c.T_cl_init).norm(), 1e-12);
    EXPECT_LT(poseError(r->stereo.T_right_left, c.T_rl_init).norm(), 1e-12);
  }
}

TEST(CoCalibration, ASecondOpinionCatchesAnEstimateFarFromTheGuessInAnotherMinimum) {
  // A co start 3 deg / 0.3 m off can settle 2.1 m off along the optical axis, declared
  // converged. An estimate that far from the initial guess is solved again from the guess
  // with the same clouds (CoCalibrationSettings::confirm_*); a converged solve 2 m away from it
  // means two minima, and the estimate is not trusted.
  SimOptions o;
  o.frames = 26;
  o.seed = 3;
  const Simulator sim(o);
  std::mt19937_64 rng(3);
  const Eigen::Isometry3d truth = sim.rig().T_cam_lidar;
  const Eigen::Isometry3d T_init = perturb(truth, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  std::vector<Keyframe> kfs;  // 6 keyframes with their stereo clouds
  for (int i = 0; i < o.frames; i += 5)
    kfs.push_back(makeKeyframe(sim.renderFrame(i), sim.rig(), T_init, sim.rig().T_right_left));
  std::vector<const Keyframe*> window;
  for (const Keyframe& kf : kfs) window.push_back(&kf);
  const LidarStereoSettings ls;
  const LidarStereoResult good = solveLidarStereo(window, T_init, ls);
  ASSERT_TRUE(good.converged) << good.message;
  ASSERT_LT(poseError(good.T_cam_lidar, truth).tail<3>().norm(), 0.02);
  const CoCalibrationSettings s;
  double seconds = -1;
  // 3 deg / 0.3 m from the guess: within confirm_beyond_* (5 deg / 0.5 m), not asked.
  EXPECT_EQ(secondOpinion(window, T_init, good, ls, s, &seconds), "");
  EXPECT_EQ(seconds, 0.0);
  // Asked (limits lowered), the solve from the guess agrees.
  CoCalibrationSettings ask = s;
  ask.confirm_beyond_deg = 0.5, ask.confirm_beyond_m = 0.05;
  EXPECT_EQ(secondOpinion(window, T_init, good, ls, ask, &seconds), "");
  EXPECT_GT(seconds, 0.0);
  // The same estimate moved 2 m along the optical axis, as that start's was.
  LidarStereoResult far = good;
  far.T_cam_lidar.pretranslate(Eigen::Vector3d(0, 0, 2.0));
  const std::string doubt = secondOpinion(window, T_init, far, ls, s, &seconds);
  EXPECT_NE(doubt.find("two minima"), std::string::npos) << doubt;
  std::cout << "[ co       ] " << doubt << "\n";
  // An estimate not converged is not second-guessed.
  far.converged = false;
  EXPECT_EQ(secondOpinion(window, T_init, far, ls, s), "");
}

TEST(CoCalibration, TheLidarEstimatesSensitivityToTheStereoPairIsWhatAPerturbedPairDoes) {
  // Co-calibration propagates the stereo pair's uncertainty into the LiDAR
  // covariance through the LiDAR estimate's sensitivity to the pair (central differences of the
  // fine stage). A pair perturbed in all four of its axes at once, once, moves the fine stage's
  // estimate as that sensitivity predicts; the clouds are left as they were.
  SimOptions o;
  o.frames = 26;
  o.seed = 3;
  const Simulator sim(o);
  const StereoRig& rig = sim.rig();
  std::vector<Keyframe> kfs;  // 6 keyframes with their stereo clouds
  for (int i = 0; i < o.frames; i += 5)
    kfs.push_back(makeKeyframe(sim.renderFrame(i), rig, rig.T_cam_lidar, rig.T_right_left));
  std::vector<Keyframe*> window;
  for (Keyframe& kf : kfs) window.push_back(&kf);
  const std::vector<const Keyframe*> cwin(window.begin(), window.end());
  const CoCalibrationSettings s;
  for (Keyframe* kf : window) retriangulateStereo(kf, rig, kf->T_right_left_used, s.stereo_cloud);
  LidarStereoSettings ls = coLidarStereoSettings(s);
  ls.check_window_halves = false;
  const LidarStereoResult base = solveLidarStereo(cwin, rig.T_cam_lidar, ls);
  ASSERT_TRUE(base.converged) << base.message;
  const std::vector<StereoPoint> points_before = kfs[2].stereo.points;
  double seconds = -1;
  const Matrix6d J = lidarSensitivityToStereo(window, rig, base, ls, s, &seconds);
  std::cout << "[ co       ] d T_cam_lidar / d T_right_left (" << seconds << " s):\n" << J << "\n";
  // Restored: the same points, the same extrinsic.
  ASSERT_EQ(kfs[2].stereo.points.size(), points_before.size());
  for (size_t i = 0; i < points_before.size(); i += 97)
    EXPECT_EQ(kfs[2].stereo.points[i].p, points_before[i].p);
  EXPECT_TRUE(kfs[2].T_right_left_used.isApprox(rig.T_right_left));
  // The clouds' yaw and the length are the solve's own nuisances: no column; the others have one.
  EXPECT_TRUE(J.col(1).isZero());
  EXPECT_TRUE(J.col(3).isZero());
  for (int k : {0, 2, 4, 5}) EXPECT_GT(J.col(k).norm(), 0.0) << "column " << k;
  // Rotation 0.015 deg about x and -0.015 deg about z, baseline +3 mm in y and -3 mm in z.
  Vector6d delta;
  delta << 0.015 / kDegPerRad, 0, -0.015 / kDegPerRad, 0, 0.003, -0.003;
  for (Keyframe* kf : window)
    retriangulateStereo(kf, rig, perturb(rig.T_right_left, delta), s.stereo_cloud);
  LidarStereoSettings fine = ls;
  fine.run_coarse = false;
  fine.converge_rot_deg = s.lidar.converge_rot_deg;
  fine.converge_trans_m = s.lidar.converge_trans_m;
  fine.initial_stereo_yaw_rad = base.stereo_yaw_rad;
  const LidarStereoResult moved_solve = solveLidarStereo(cwin, base.T_cam_lidar, fine);
  ASSERT_TRUE(moved_solve.settled) << moved_solve.message;
  const Vector6d moved = poseError(moved_solve.T_cam_lidar, base.T_cam_lidar);
  const Vector6d predicted = J * delta;
  std::cout << "[ co       ] moved     " << moved.transpose() << "\n"
            << "[ co       ] predicted " << predicted.transpose() << "\n";
  // Not negligible, and the rotation as predicted within 50 % (plus the fine stage's settle
  // tolerance). The translation is not linear at this step (measured: moved 8.7 mm, predicted
  // 10.3 mm, 7.8 mm apart): only its size is checked, within a factor of 2.
  EXPECT_GT(predicted.head<3>().norm() * kDegPerRad, 0.005);
  EXPECT_LT((moved - predicted).head<3>().norm() * kDegPerRad,
            0.5 * predicted.head<3>().norm() * kDegPerRad + 0.002);
  EXPECT_GT(moved.tail<3>().norm(), 0.5 * predicted.tail<3>().norm());
  EXPECT_LT(moved.tail<3>().norm(), 2.0 * predicted.tail<3>().norm());
}

TEST(CoCalibration, AskedForASecondOpinionThatDisagreesTheResultIsNotConverged) {
  // The wiring of secondOpinion into coCalibrate: with the limits set so that it is always asked
  // and always disagrees (a negative tolerance), a window that converges otherwise (the test
  // above) is reported not converged, with the second opinion's reason; its estimate is kept.
  CoCase c = shortBaselineCase();
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  CoCalibrationSettings s;
  s.confirm_beyond_deg = 0, s.confirm_beyond_m = 0;
  s.confirm_disagree_deg = -1, s.confirm_disagree_m = -1;
  const CoCalibrationResult r = coCalibrate(c.w.window(), w.rig, T_cl_init, T_rl_init, s);
  EXPECT_TRUE(r.stable);
  EXPECT_FALSE(r.converged);
  EXPECT_FALSE(r.lidar.converged);
  EXPECT_NE(r.message.find("two minima"), std::string::npos) << r.message;
  EXPECT_LT(poseError(r.lidar.T_cam_lidar, truth.T_cam_lidar).tail<3>().norm(), 0.03);
}

TEST(CoCalibration, RunawayLidarEstimatesAreNotTaken) {
  // The runaway rule, made to fire: with divergence bounds of 1 deg / 5 cm, every LiDAR-stereo
  // solve from a start 3 deg / 0.3 m off ends beyond them. No such estimate may be taken, and the
  // result keeps the initial guesses (never worse than the last good estimate) and says why.
  CoCase c = coCase(5, 0.2, 0.01);
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  const std::vector<Keyframe*> window = c.w.window();
  CoCalibrationSettings s;
  s.stereo_from_features = false;  // the stereo start is then the result's, as given
  s.max_rounds = 2;
  s.lidar.max_correction_rot_deg = 1.0;
  s.lidar.max_correction_trans_m = 0.05;
  const CoCalibrationResult r = coCalibrate(window, w.rig, T_cl_init, T_rl_init, s);
  std::cout << "[ co       ] " << r.rounds << " rounds, " << r.rejected
            << " rejected: " << r.message << "\n";
  EXPECT_EQ(r.rejected, 2);
  EXPECT_FALSE(r.converged);
  EXPECT_FALSE(r.lidar.converged);
  EXPECT_NE(r.message.find("ran away"), std::string::npos) << r.message;
  EXPECT_LT(poseError(r.lidar.T_cam_lidar, T_cl_init).norm(), 1e-12);
  EXPECT_LT(poseError(r.stereo.T_right_left, T_rl_init).norm(), 1e-12);
  // The same window and start with the default bounds: the estimate is taken and is good.
  CoCalibrationSettings d;
  d.max_rounds = 2;
  const CoCalibrationResult ok = coCalibrate(window, w.rig, T_cl_init, T_rl_init, d);
  EXPECT_EQ(ok.rejected, 0);
  EXPECT_LT(poseError(ok.lidar.T_cam_lidar, truth.T_cam_lidar).tail<3>().norm(), 0.05);
}

TEST(CoCalibration, TheAlternationsSolvesFollowTheStereoSurfaceByDefault) {
  // LiDAR-stereo alone keeps the faces' normals; the alternation's solves, where the clouds' scale
  // is free, take co-calibration's own setting.
  CoCalibrationSettings s;
  EXPECT_EQ(s.lidar.fine_stereo_normal_px, 0);
  EXPECT_EQ(s.fine_stereo_normal_px, 6);
  EXPECT_EQ(coLidarStereoSettings(s).fine_stereo_normal_px, 6);
  EXPECT_TRUE(coLidarStereoSettings(s).estimate_stereo_scale);
  s.fine_stereo_normal_px = 0;
  s.lidar.fine_stereo_normal_px = 4;
  EXPECT_EQ(coLidarStereoSettings(s).fine_stereo_normal_px, 0);
}

TEST(CoCalibration, StopsWhenARejectedRoundWouldRepeatItself) {
  // Trial 0 of `tescalib_eval --mode co --init-rot-deg 10 --init-trans-m 1 --init-stereo-rot-deg 1
  // --init-stereo-trans-m 0.1 --seed 2 --window 10`: window 0
  // of the generated urban drive of seed 1 (100 frames). With the LiDAR 10 deg / 1 m off, beyond
  // the alternation's basin, the LiDAR-stereo solves run away from the initial guess from round 2
  // on, the same way each time. Two rejections in a row from the same estimates and clouds end
  // the alternation, and the result keeps the last estimates taken.
  CoCase c = evalCoTrial(1, 2, 10.0, 1.0);
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  const std::vector<Keyframe*> window = c.w.window();
  CoCalibrationSettings s;
  s.stereo_from_features = false;  // round 1 photometric
  s.max_rounds = 6;
  // Not the defaults: one upright SGBM pass and the faces' normals alone, under which this start's
  // solves run away.
  s.stereo_cloud.sgbm_both_ways = false;
  s.fine_stereo_normal_px = 0;
  const CoCalibrationResult r = coCalibrate(window, w.rig, T_cl_init, T_rl_init, s);
  std::cout << "[ co       ] " << r.rounds << " rounds, " << r.rejected << " rejected, "
            << r.seconds << " s: " << r.message << "\n";
  EXPECT_FALSE(r.converged);
  EXPECT_FALSE(r.lidar.converged);
  EXPECT_GE(r.rejected, 2);
  EXPECT_NE(r.message.find("the last two started from the same estimates and clouds"),
            std::string::npos)
      << r.message;
  EXPECT_LT(r.rounds, s.max_rounds);
  // Not the runaway estimate (beyond 2.5 m from the guess): the one taken before.
  EXPECT_LT(poseError(r.lidar.T_cam_lidar, T_cl_init).tail<3>().norm(), 1.5);
}

TEST(CoCalibration, StereoFromFeaturesConvergesFromThatStart) {
  // A start beyond the alternation's basin (trial 0 of StopsWhenARejectedRoundWouldRepeatItself's
  // command with --seed 1: the LiDAR 10 deg / 1 m off), with round 1 taking the stereo pair from
  // left-right feature matches (no depth needed) and solving LiDAR-stereo first, with the
  // wide-basin search: both extrinsics converge (12 of 12 such generated starts).
  CoCase c = evalCoTrial(1, 1, 10.0, 1.0);
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  CoCalibrationSettings s;
  s.stereo_from_features = true;
  const CoCalibrationResult r = coCalibrate(c.w.window(), w.rig, T_cl_init, T_rl_init, s);
  const Vector6d el = poseError(r.lidar.T_cam_lidar, truth.T_cam_lidar);
  const Vector6d es = poseError(r.stereo.T_right_left, truth.T_right_left);
  const Vector6d ef = poseError(r.features.T_right_left, truth.T_right_left);
  std::cout << "[ co       ] features: " << r.features.inliers << " inliers, pair "
            << ef.head<3>().norm() * kDegPerRad << " deg off; " << r.rounds << " rounds, "
            << r.seconds << " s; LiDAR " << el.head<3>().norm() * kDegPerRad << " deg "
            << el.tail<3>().norm() * 100 << " cm; stereo " << es.head<3>().norm() * kDegPerRad
            << " deg " << es.tail<3>().norm() * 1000 << " mm; " << r.message << "\n";
  ASSERT_TRUE(r.features.ok) << r.features.message;
  EXPECT_LT(ef.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_TRUE(r.converged) << r.message;
  // Within what a converged co-calibration of 10 keyframes reaches on fresh rigs (README: 0.1 deg
  // / 1.5 cm); on this window 0.03 deg / 1.1 cm.
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(el.tail<3>().norm(), 0.015);
  EXPECT_LT(es.head<3>().norm() * kDegPerRad, 0.02);
  EXPECT_LT(es.tail<3>().norm(), 0.005);
}

TEST(CoCalibration, LeavesAWrongPhotometricYawMinimum) {
  // The one failure of the 54 held-out benchmark starts (doc/benchmarks.md): window 0 of the
  // generated urban drive of seed 31 (100 frames), trial 0 of `tescalib_eval --seed 61`. Its
  // round-1 photometric solve, with the LiDAR 2.7 deg / 0.28 m off, settles with the right
  // camera's yaw 0.9 deg off, and the LiDAR-stereo solves say so (clouds' yaw -0.56..-0.88 deg);
  // without the hand-over the alternation stays there (and the LiDAR ends 1.6 m off).
  CoCase c = evalCoTrial(31, 61, 3.0, 0.3);
  const auto& [truth, T_cl_init, T_rl_init, w] = c;
  const std::vector<Keyframe*> window = c.w.window();

  // Round 1 photometric (without the stereo pair from feature matches, which starts elsewhere).
  CoCalibrationSettings photometric_first;
  photometric_first.stereo_from_features = false;
  CoCalibrationSettings without = photometric_first;
  without.yaw_handover_deg = -1;
  without.max_rounds = 4;
  const CoCalibrationResult bad = coCalibrate(window, w.rig, T_cl_init, T_rl_init, without);
  const Vector6d eb = poseError(bad.stereo.T_right_left, truth.T_right_left);
  std::cout << "[ co       ] without the hand-over, after " << bad.rounds << " rounds: stereo yaw "
            << eb[1] * kDegPerRad << " deg off, LiDAR "
            << poseError(bad.lidar.T_cam_lidar, truth.T_cam_lidar).tail<3>().norm() << " m off\n";
  EXPECT_GT(std::fabs(eb[1]) * kDegPerRad, 0.5);

  const CoCalibrationResult r = coCalibrate(window, w.rig, T_cl_init, T_rl_init, photometric_first);
  const Vector6d el = poseError(r.lidar.T_cam_lidar, truth.T_cam_lidar);
  const Vector6d es = poseError(r.stereo.T_right_left, truth.T_right_left);
  std::cout << "[ co       ] " << r.rounds << " rounds, " << r.yaw_handovers << " hand-overs, "
            << r.seconds << " s; LiDAR " << el.head<3>().norm() * kDegPerRad << " deg "
            << el.tail<3>().norm() * 100 << " cm; stereo " << es.head<3>().norm() * kDegPerRad
            << " deg " << es.tail<3>().norm() * 1000 << " mm; " << r.message << "\n";
  EXPECT_GE(r.yaw_handovers, 1);
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LT(el.head<3>().norm() * kDegPerRad, 0.2);
  EXPECT_LT(el.tail<3>().norm(), 0.03);
  EXPECT_LT(std::fabs(es[1]) * kDegPerRad, 0.02);
  EXPECT_LT(es.tail<3>().norm(), 0.005);
}

TEST(CoCalibration, APairThatCannotBeRectifiedEndsTheAlternationWithoutThrowing) {
  // From the LiDAR 90 deg / 3 m off, a round's photometric solve can match nothing and leave a
  // baseline more vertical than horizontal; rectifying the clouds with it throws (DataError),
  // which must not escape coCalibrate. Here the pair starts so: the
  // baseline straight down. The alternation must stop, not converged, and say why.
  const StereoRig rig = coCase(3, 0.0, 0.0).truth;
  Eigen::Isometry3d down = rig.T_right_left;
  down.translation() = Eigen::Vector3d(0.0, rig.T_right_left.translation().norm(), 0.0);
  EXPECT_GT(rectifiedBaseline(rig, rig.T_right_left), 0.5);
  EXPECT_LE(rectifiedBaseline(rig, down), 0.0);
  Eigen::Isometry3d left_of_it = rig.T_right_left;  // the "right" camera to the left
  left_of_it.translation() = -rig.T_right_left.translation();
  EXPECT_LE(rectifiedBaseline(rig, left_of_it), 0.0);

  CoCase c = coCase(3, 0.0, 0.0);
  const std::vector<Keyframe*> window = c.w.window();
  CoCalibrationSettings s;
  s.stereo_from_features = false;  // round 1 photometric, from the pair as given
  s.max_rounds = 3;
  CoCalibrationResult r;
  ASSERT_NO_THROW(r = coCalibrate(window, c.w.rig, c.T_cl_init, down, s));
  std::cout << "[ co       ] " << r.rounds << " rounds: " << r.message << "\n";
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("cannot be rectified side by side"), std::string::npos) << r.message;
}
