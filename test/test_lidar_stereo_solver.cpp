// LiDAR-stereo solver: exact-ground-truth recovery on a ray-cast plane scene (independent of SGBM
// and of the scene generator), an honest failure on a scene without structure, and a real KITTI
// window (skipped without ../shared).
#include <atomic>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/solvers/lidar_stereo_fine.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/residuals/lidar_ring_offset_residual.h"
#include "tescalib/core/uncertainty/trust.h"
#include "test_util.h"

using namespace tescalib;

namespace {

struct Plane {
  Eigen::Vector3d n;  ///< unit normal (camera frame)
  double h;           ///< n^T X = h
};

/// Nearest positive intersection of a ray with the planes (camera frame); inf when none.
double cast(const std::vector<Plane>& planes, const Eigen::Vector3d& o, const Eigen::Vector3d& r,
            int* hit = nullptr) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < planes.size(); ++i) {
    const double den = planes[i].n.dot(r);
    if (std::fabs(den) < 1e-9) continue;
    const double t = (planes[i].h - planes[i].n.dot(o)) / den;
    if (t > 1e-6 && t < best) best = t, hit ? * hit = int(i) : 0;
  }
  return best;
}

StereoRig kittiLikeRig() {
  StereoRig rig;
  rig.left.fx = rig.left.fy = 718.856;
  rig.left.cx = 607.19, rig.left.cy = 185.22;
  rig.left.width = 1241, rig.left.height = 376;
  rig.right = rig.left;
  rig.T_right_left.translation() = Eigen::Vector3d(-0.54, 0, 0);
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // LiDAR x forward, y left, z up -> camera
  rig.T_cam_lidar.linear() = expSO3(Eigen::Vector3d(0.004, -0.01, 0.006)) * R;
  rig.T_cam_lidar.translation() = Eigen::Vector3d(0.06, -0.08, -0.27);
  return rig;
}

/// Tilts of the disparity error across the image (px per unit of normalised column x) on the
/// ground (normal within 37 deg of camera y) and on the lateral surfaces (within 45 deg of x).
struct SurfaceTilts {
  double ground = 0.0, lateral = 0.0;
};

/// A keyframe of the plane scene: LiDAR ray cast from the LiDAR, disparity ray cast from the
/// camera (exact, plus Gaussian noise), stereo points with the plane normals. `right_yaw`: the
/// true right camera is rotated by this (rad, about its y axis) from the one the disparities were
/// rectified for, so they are short by f yaw (1 + x_r^2). `disparity_offset` (px) is added to
/// every disparity, `tilts` to the ground's and the lateral surfaces'.
Keyframe planeKeyframe(const std::vector<Plane>& planes, const StereoRig& rig, uint64_t seed,
                       double right_yaw = 0.0, double disparity_offset = 0.0,
                       double baseline_scale = 1.0,
                       const std::vector<double>& ring_range_offsets = {},
                       const SurfaceTilts& tilts = {}) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> range_noise(0.0, 0.01), disp_noise(0.0, 0.2);
  Keyframe kf;
  const Eigen::Isometry3d T_lidar_cam = rig.T_cam_lidar.inverse();
  for (int ring = 63; ring >= 0; --ring) {
    const double e = (-24.9 + 26.9 * ring / 63.0) / kDegPerRad;
    for (int k = 0; k < 2000; ++k) {
      const double a = 2 * M_PI * (k + 0.5) / 2000;
      const Eigen::Vector3d dir(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      const double t = cast(planes, rig.T_cam_lidar.translation(), rig.T_cam_lidar.linear() * dir);
      if (!std::isfinite(t) || t > 100) continue;
      const double offset = ring_range_offsets.empty() ? 0.0 : ring_range_offsets[ring];
      const Eigen::Vector3d p = (t + offset + range_noise(rng)) * dir;
      LidarPoint lp;
      lp.x = float(p.x()), lp.y = float(p.y()), lp.z = float(p.z());
      lp.ring = uint16_t(ring);
      kf.scan.push_back(lp);
    }
  }
  (void)T_lidar_cam;
  LidarMeshSettings ms;
  ms.view_axis = rig.T_cam_lidar.linear().transpose() * Eigen::Vector3d::UnitZ();
  ms.view_half_angle_deg = 70;
  kf.mesh = buildLidarMesh(kf.scan, ms);

  StereoCloud& st = kf.stereo;
  st.fx = rig.left.fx, st.fy = rig.left.fy, st.cx = rig.left.cx, st.cy = rig.left.cy;
  st.baseline = 0.54;
  st.disparity = cv::Mat(rig.left.height, rig.left.width, CV_32F,
                         cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int v = 0; v < st.disparity.rows; ++v) {
    for (int u = 0; u < st.disparity.cols; ++u) {
      const Eigen::Vector3d r((u - st.cx) / st.fx, (v - st.cy) / st.fy, 1.0);
      int hit = -1;
      const double t = cast(planes, Eigen::Vector3d::Zero(), r, &hit);
      if (!std::isfinite(t) || t > 40) continue;
      const double d_true = st.fx * baseline_scale * st.baseline / t;
      const double xr = (u - d_true - st.cx) / st.fx;
      const Eigen::Vector3d& n_hit = planes[hit].n;
      const double tilt = std::fabs(n_hit.y()) > 0.8   ? tilts.ground * r.x()
                          : std::fabs(n_hit.x()) > 0.7 ? tilts.lateral * r.x()
                                                       : 0.0;
      const double d =
          d_true - st.fx * right_yaw * (1.0 + xr * xr) + disparity_offset + tilt + disp_noise(rng);
      st.disparity.at<float>(v, u) = float(d);
      if (u % 4 == 0 && v % 4 == 0) {
        StereoPoint sp;
        sp.p = st.pointAt(u, v, d).cast<float>();
        Eigen::Vector3d n = planes[hit].n;
        if (n.dot(sp.p.cast<double>()) > 0) n = -n;
        sp.n = n.cast<float>();
        sp.disparity = float(d);
        st.points.push_back(sp);
      }
    }
  }
  return kf;
}

std::vector<Plane> streetCanyon(double shift) {
  // Ground, two facades, a building across the street, an oblique wall and two boxes' faces.
  return {{Eigen::Vector3d(0, -1, 0), -1.65},
          {Eigen::Vector3d(1, 0, 0), -6.0 + shift},
          {Eigen::Vector3d(-1, 0, 0), -7.0},
          {Eigen::Vector3d(0, 0, -1), -32.0 - shift},
          {Eigen::Vector3d(0.6, 0, -0.8).normalized(), -14.0},
          {Eigen::Vector3d(0, 0, -1), -9.0 - shift},
          {Eigen::Vector3d(-1, 0, 0), -3.5 - 0.3 * shift}};
}

/// Three views of the street canyon 0.7 m apart (noise seeds first_seed, +1, +2), clouds
/// rectified with a right camera `right_yaw` off, every disparity `disparity_offset` px more,
/// each LiDAR ring's ranges `ring_range_offsets[ring]` m longer (none when empty).
std::vector<Keyframe> canyonKeyframes(const StereoRig& rig, uint64_t first_seed,
                                      double right_yaw = 0.0, double disparity_offset = 0.0,
                                      double baseline_scale = 1.0,
                                      const std::vector<double>& ring_range_offsets = {},
                                      const SurfaceTilts& tilts = {}) {
  std::vector<Keyframe> kfs;
  for (int k = 0; k < 3; ++k)
    kfs.push_back(planeKeyframe(streetCanyon(0.7 * k), rig, first_seed + k, right_yaw,
                                disparity_offset, baseline_scale, ring_range_offsets, tilts));
  return kfs;
}

std::vector<const Keyframe*> windowOf(const std::vector<Keyframe>& kfs) {
  std::vector<const Keyframe*> window;
  for (const auto& kf : kfs) window.push_back(&kf);
  return window;
}

/// The noise of planeKeyframe's clouds; the stereo scale held (the clouds' baseline is exact):
/// these tests study the pose, the yaw and the offset, the scale has its own test.
LidarStereoSettings testSettings() {
  LidarStereoSettings s;
  s.disparity_sigma = 0.2;
  s.lidar_range_sigma = 0.01;
  s.estimate_stereo_scale = false;
  return s;
}

/// The canyon window (seed 11) and `biased`, the same window with a common bias in its clouds,
/// both solved from one start 3 deg / 0.3 m off (drawn from `start_seed`), with the model's
/// disparity bias, its measurement and the split-window check off: what the bias alone moves.
std::pair<LidarStereoResult, LidarStereoResult> solvedWithAndWithoutBias(
    const StereoRig& rig, const std::vector<Keyframe>& biased, uint64_t start_seed) {
  LidarStereoSettings settings = testSettings();
  settings.model_sigma_disparity_px = 0;
  settings.measure_disparity_offset = false;
  settings.check_window_halves = false;
  std::mt19937_64 rng(start_seed);
  const Eigen::Isometry3d T_init =
      perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  const std::vector<Keyframe> plain = canyonKeyframes(rig, 11);
  return {solveLidarStereo(windowOf(plain), T_init, settings),
          solveLidarStereo(windowOf(biased), T_init, settings)};
}

}  // namespace

TEST(LidarStereoSolver, RecoversKnownPerturbationsOnAPlaneScene) {
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 11);
  const std::vector<const Keyframe*> window = windowOf(kfs);
  // These disparities carry no common bias (truth + white noise), so the trust flags here are
  // about the residuals alone: with the default 0.05 px disparity bias, this window of three
  // nearly equal views of planes 6-32 m away lets tz move 1.2 cm and calls it untrusted.
  LidarStereoSettings settings = testSettings();
  settings.model_sigma_disparity_px = 0;
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 3; ++trial) {
    const Vector6d delta = randomPerturbation(3.0 / kDegPerRad, 0.3, rng);
    const LidarStereoResult r = solveLidarStereo(window, perturb(rig.T_cam_lidar, delta), settings);
    const Vector6d e = poseError(r.T_cam_lidar, rig.T_cam_lidar);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.05) << "trial " << trial;
    EXPECT_LT(e.tail<3>().norm(), 0.01) << "trial " << trial;
    EXPECT_GT(r.fine_inliers, 1000);
    for (int i = 0; i < 6; ++i) EXPECT_TRUE(r.observable[i]) << "axis " << i;
    EXPECT_NEAR(r.bias_sensitivity(5, 0), -0.235, 0.02);  // m of tz per px of disparity offset
  }
}

TEST(LidarRingOffsetResidual, TakesTheRingsOffsetsOutOfTheFace) {
  // A road face 15 m ahead, two vertices on the lower ring, one on the upper; each ring's
  // ranges too long by its offset. The stereo point lies on the true face, at its centroid: the
  // residual with the true offsets is near 0, without them it is the offsets' move.
  const Eigen::Vector3d a_true(15.0, -0.1, -1.7), b_true(15.0, 0.1, -1.7), c_true(16.2, 0.0, -1.7);
  const double o_lo = 0.04, o_hi = -0.03;
  const Eigen::Vector3d a = a_true + o_lo * a_true.normalized(),
                        b = b_true + o_lo * b_true.normalized(),
                        c = c_true + o_hi * c_true.normalized();
  LidarStereoAssociation as;
  as.p_l = (a + b + c) / 3;
  as.n_l = (b - a).cross(c - a).normalized();
  if (as.n_l.dot(as.p_l) > 0) as.n_l = -as.n_l;
  as.q = as.p_l, as.m = as.n_l;
  as.p_s = (a_true + b_true + c_true) / 3;
  as.ring = 10, as.lower_share = 2.0 / 3, as.range_gain = as.n_l.dot(as.p_l.normalized());
  as.d = 30.0;
  const double zero[6] = {0, 0, 0, 0, 0, 0}, one = 1.0, no_yaw = 0.0, none = 0.0;
  const LidarRingOffsetResidual with(as, Eigen::Vector3d::Zero());
  double r_with = 0, r_without = 0;
  with(zero, &one, &no_yaw, &o_lo, &o_hi, &r_with);
  with(zero, &one, &no_yaw, &none, &none, &r_without);
  // At 83 deg incidence the offsets move the face along its normal by 0.12 of their share.
  EXPECT_NEAR(r_without, -0.0021, 0.0003) << r_without;  // m (inv_sigma 1), behind the face
  EXPECT_LT(std::fabs(r_with), 0.1 * std::fabs(r_without)) << r_with;
}

TEST(LidarStereoSolver, EstimatesTheLidarRingsRangeOffsets) {
  // Each laser's ranges 3 cm rms off, fixed per ring (a HDL-64E's calibration residue): the fine
  // stage finds each ring's offset from the stereo surfaces it crosses.
  const StereoRig rig = kittiLikeRig();
  std::mt19937_64 rng(17);
  std::normal_distribution<double> laser(0.0, 0.03);
  std::vector<double> offsets(64);
  for (double& o : offsets) o = laser(rng);
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 31, 0.0, 0.0, 1.0, offsets);
  LidarStereoSettings settings = testSettings();
  settings.ring_range_sigma_m = 0.1;
  const Eigen::Isometry3d start = perturb(rig.T_cam_lidar, randomPerturbation(0.01, 0.03, rng));
  const LidarStereoResult r = solveLidarStereo(windowOf(kfs), start, settings);
  ASSERT_EQ(r.ring_range_offsets_m.size(), 64u);
  // Their common part is not estimated (RingOffsetMean): the truth less its mean over the rings
  // the associations saw.
  double mean = 0;
  int seen = 0;
  for (size_t ring = 0; ring < 64; ++ring) {
    if (r.ring_range_offsets_m[ring] == 0.0) continue;  // no association saw it
    mean += offsets[ring], ++seen;
  }
  ASSERT_GT(seen, 30);
  mean /= seen;
  double sum_sq = 0, truth_sq = 0;
  for (size_t ring = 0; ring < 64; ++ring) {
    if (r.ring_range_offsets_m[ring] == 0.0) continue;
    sum_sq += std::pow(r.ring_range_offsets_m[ring] - (offsets[ring] - mean), 2);
    truth_sq += std::pow(offsets[ring] - mean, 2);
  }
  EXPECT_LT(std::sqrt(sum_sq / seen), 0.2 * std::sqrt(truth_sq / seen));
  // Held at 0, the same offsets leave a larger share of the residuals unexplained.
  settings.ring_range_sigma_m = 0;
  const LidarStereoResult held = solveLidarStereo(windowOf(kfs), start, settings);
  EXPECT_TRUE(held.ring_range_offsets_m.empty());
  EXPECT_GT(held.residual_scale, 1.2 * r.residual_scale);
}

TEST(LidarStereoSolver, WithAConsistentSampleTheEstimateDoesNotDependOnTheGuessViewCone) {
  // The node and tescalib_eval keep the faces within a cone about the guess' camera axis. With
  // LidarMeshSettings::consistent_sample the faces the solver draws are chosen by their place in
  // the range image, so two guesses 3 deg / 0.3 m apart, each with meshes built around its own
  // axis, reach the same estimate. (With the default evenly strided sample these two end
  // 0.0115 deg / 1.6 mm apart: about the statistical sigma.)
  const StereoRig rig = kittiLikeRig();
  std::vector<Keyframe> kfs = canyonKeyframes(rig, 21);
  LidarStereoSettings settings = testSettings();
  settings.model_sigma_disparity_px = 0;
  settings.check_window_halves = false;
  std::mt19937_64 rng(9);
  std::vector<Eigen::Isometry3d> ends;
  for (int trial = 0; trial < 2; ++trial) {
    const Eigen::Isometry3d guess =
        perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
    LidarMeshSettings ms;
    ms.view_axis = guess.linear().transpose() * Eigen::Vector3d::UnitZ();
    ms.view_half_angle_deg = 70;
    ms.consistent_sample = true;
    for (Keyframe& kf : kfs) kf.mesh = buildLidarMesh(kf.scan, ms);
    const LidarStereoResult r = solveLidarStereo(windowOf(kfs), guess, settings);
    ASSERT_TRUE(r.converged) << r.message;
    ends.push_back(r.T_cam_lidar);
  }
  const Vector6d d = poseError(ends[0], ends[1]);
  EXPECT_LT(d.head<3>().norm() * kDegPerRad, 0.001);
  EXPECT_LT(d.tail<3>().norm(), 2e-4);
}

TEST(LidarStereoSolver, EstimatesTheStereoScaleByDefault) {
  // Clouds of a pair whose true baseline is 1 % longer than the one they were computed with (an
  // f x B error, as real pairs have): by default the solver estimates the clouds' scale and
  // finds the extrinsic; with the scale held, the optical axis absorbs it.
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 41, 0.0, 0.0, 1.01);
  std::mt19937_64 rng(3);
  const Eigen::Isometry3d T_init =
      perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  LidarStereoSettings s = testSettings();
  s.estimate_stereo_scale = LidarStereoSettings{}.estimate_stereo_scale;
  ASSERT_TRUE(s.estimate_stereo_scale);
  s.model_sigma_disparity_px = 0;
  const LidarStereoResult with = solveLidarStereo(windowOf(kfs), T_init, s);
  const Vector6d e = poseError(with.T_cam_lidar, rig.T_cam_lidar);
  s.estimate_stereo_scale = false;
  const LidarStereoResult held = solveLidarStereo(windowOf(kfs), T_init, s);
  const Vector6d e0 = poseError(held.T_cam_lidar, rig.T_cam_lidar);
  std::printf("scale %.4f (true 1.01), error %.4f deg %.2f cm; held: %.4f deg %.2f cm\n",
              with.stereo_scale, e.head<3>().norm() * kDegPerRad, 100 * e.tail<3>().norm(),
              e0.head<3>().norm() * kDegPerRad, 100 * e0.tail<3>().norm());
  EXPECT_TRUE(with.converged) << with.message;
  EXPECT_NEAR(with.stereo_scale, 1.01, 0.002);
  EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.05);
  EXPECT_LT(e.tail<3>().norm(), 0.01);
  EXPECT_GT(e0.tail<3>().norm(), 3 * e.tail<3>().norm());
  EXPECT_GT(e0.tail<3>().norm(), 0.02);
  // The pose's sensitivity to the scale says where the pose goes with the scale held at 1.
  const Vector6d predicted = (1.0 - with.stereo_scale) * with.stereo_scale_sensitivity;
  std::printf("held minus free tz %.2f cm, predicted %.2f cm\n", 100 * (e0[5] - e[5]),
              100 * predicted[5]);
  EXPECT_NEAR(e0[5] - e[5], predicted[5], 0.3 * std::fabs(e0[5] - e[5]));
  // A window that cannot be trusted names the f x B error it found as a suspect.
  s.estimate_stereo_scale = true;
  s.max_sigma_trans_m = 0.0002;
  const LidarStereoResult strict = solveLidarStereo(windowOf(kfs), T_init, s);
  EXPECT_FALSE(strict.converged);
  EXPECT_NE(strict.message.find("f x B looks +1.0 %"), std::string::npos) << strict.message;
  // Clouds with an exact baseline do not raise that suspicion.
  const std::vector<Keyframe> exact = canyonKeyframes(rig, 41);
  const LidarStereoResult strict_exact = solveLidarStereo(windowOf(exact), T_init, s);
  EXPECT_FALSE(strict_exact.converged);
  EXPECT_EQ(strict_exact.message.find("f x B"), std::string::npos) << strict_exact.message;
}

TEST(LidarStereoSolver, TheBiasSensitivityPredictsWhatADisparityOffsetDoes) {
  // bias_sensitivity column 0 is the first-order move of the estimate per px of a disparity
  // offset common to every stereo point; the published covariance adds it times the model's
  // bias sigma. Checked against the solver itself: the same window (same noise) with every
  // disparity 0.1 px larger moves the estimate by h * 0.1 (tz by about 2.4 cm here).
  const StereoRig rig = kittiLikeRig();
  const double offset = 0.1;
  const auto [a, b] = solvedWithAndWithoutBias(rig, canyonKeyframes(rig, 11, 0.0, offset), 5);
  ASSERT_TRUE(a.covariance_known && b.covariance_known) << a.message << " / " << b.message;
  const Vector6d moved = poseError(b.T_cam_lidar, a.T_cam_lidar);
  const Vector6d predicted = offset * a.bias_sensitivity.col(0);
  std::printf(
      "moved     [%+.4f %+.4f %+.4f] deg, [%+.2f %+.2f %+.2f] cm\n"
      "predicted [%+.4f %+.4f %+.4f] deg, [%+.2f %+.2f %+.2f] cm\n",
      moved[0] * kDegPerRad, moved[1] * kDegPerRad, moved[2] * kDegPerRad, 100 * moved[3],
      100 * moved[4], 100 * moved[5], predicted[0] * kDegPerRad, predicted[1] * kDegPerRad,
      predicted[2] * kDegPerRad, 100 * predicted[3], 100 * predicted[4], 100 * predicted[5]);
  EXPECT_GT(std::fabs(moved[5]), 0.015);  // the offset moves tz by centimetres
  EXPECT_NEAR(moved[5], predicted[5], 0.2 * std::fabs(predicted[5]));
  EXPECT_LT((moved - predicted).head<3>().norm() * kDegPerRad, 0.01);
  EXPECT_LT((moved - predicted).tail<3>().norm(), 0.2 * predicted.tail<3>().norm());
}

namespace {

/// The canyon window solved with and without the disparity `tilts` (px per unit of normalised
/// column; `size` the one that is not 0): bias_sensitivity column `column` times `size` predicts
/// the move about rotation axis `axis` (which moves by more than 0.02 deg) within 20 %, and of the
/// whole rotation within 20 %. Returns the solve without the tilts.
LidarStereoResult expectTiltMovesAsPredicted(const SurfaceTilts& tilts, double size, int column,
                                             int axis) {
  const StereoRig rig = kittiLikeRig();
  const auto [a, b] =
      solvedWithAndWithoutBias(rig, canyonKeyframes(rig, 11, 0.0, 0.0, 1.0, {}, tilts), 7);
  EXPECT_TRUE(a.covariance_known && b.covariance_known) << a.message << " / " << b.message;
  const Vector6d moved = poseError(b.T_cam_lidar, a.T_cam_lidar);
  const Vector6d predicted = size * a.bias_sensitivity.col(column);
  std::printf("r%c moved %+.4f deg, predicted %+.4f deg; rotation moved %.4f deg, predicted %.4f\n",
              "xyz"[axis], moved[axis] * kDegPerRad, predicted[axis] * kDegPerRad,
              moved.head<3>().norm() * kDegPerRad, predicted.head<3>().norm() * kDegPerRad);
  EXPECT_GT(std::fabs(moved[axis]) * kDegPerRad, 0.02);
  EXPECT_NEAR(moved[axis], predicted[axis], 0.2 * std::fabs(predicted[axis]));
  EXPECT_LT((moved - predicted).head<3>().norm(), 0.2 * predicted.head<3>().norm());
  return a;
}

}  // namespace

TEST(LidarStereoSolver, TheBiasSensitivityPredictsWhatAGroundTiltDoes) {
  // bias_sensitivity column 4: the move per px of a tilt of the ground's disparity across the
  // image (b x px at normalised column x), which turns the estimate about the optical axis. The
  // same window with the road's disparities tilted by 0.3 px per unit of x moves the estimate by
  // h * 0.3. The covariance's sigma of that tilt grows with the rectification's roll, which is 0
  // for these clouds (a pair rectified as delivered).
  const LidarStereoSettings settings;
  const double tilt = 0.3;
  const LidarStereoResult a = expectTiltMovesAsPredicted({tilt, 0.0}, tilt, 4, 2);
  EXPECT_EQ(a.rectification_roll_deg, 0.0);
  EXPECT_EQ(groundTiltSigma(a, settings), 0.0);
  LidarStereoResult rolled = a;
  rolled.rectification_roll_deg = -0.5;
  EXPECT_DOUBLE_EQ(groundTiltSigma(rolled, settings),
                   0.5 * settings.model_sigma_ground_tilt_px_per_deg);
  // Clouds matched with the column low-pass (StereoSettings::rectified_vertical_blur_px) tilt
  // less: from model_ground_tilt_low_pass_px on, the low-passed sigma holds.
  EXPECT_EQ(a.vertical_low_pass_px, 0.0);
  rolled.vertical_low_pass_px = 0.5 * settings.model_ground_tilt_low_pass_px;
  EXPECT_DOUBLE_EQ(groundTiltSigma(rolled, settings),
                   0.5 * settings.model_sigma_ground_tilt_px_per_deg);
  rolled.vertical_low_pass_px = settings.model_ground_tilt_low_pass_px;
  EXPECT_DOUBLE_EQ(groundTiltSigma(rolled, settings),
                   0.5 * settings.model_sigma_ground_tilt_low_passed_px_per_deg);
  EXPECT_LT(settings.model_sigma_ground_tilt_low_passed_px_per_deg,
            settings.model_sigma_ground_tilt_px_per_deg);
}

TEST(LidarStereoSolver, TheBiasSensitivityPredictsWhatALateralTiltDoes) {
  // bias_sensitivity column 6: the move per px of a tilt of the lateral surfaces' disparity
  // across the image (b x px at normalised column x: the walls on the left against those on the
  // right), which turns the estimate about the camera's y axis. The same window with the walls'
  // disparities tilted by 0.5 px per unit of x moves the estimate by h * 0.5 (a smaller tilt
  // moves it by less than the solver's own stopping noise); the ground's and the other
  // surfaces' disparities are left as they are.
  const double tilt = 0.5;
  const LidarStereoResult a = expectTiltMovesAsPredicted({0.0, tilt}, tilt, 6, 1);
  // The lateral offset (column 5) is a column of its own, not the ground's (column 3).
  EXPECT_GT((a.bias_sensitivity.col(5) - a.bias_sensitivity.col(3)).norm(),
            0.5 * a.bias_sensitivity.col(5).norm());
}

TEST(LidarStereoSolver, ReassociationOnPlanesDoesNotMoveTheFixedPoint) {
  // On planes a LiDAR face compared with the stereo point at its projection keeps its distance to
  // the plane wherever T moves it (the point slides along the plane with the projection): the
  // fine stage's re-association does not feed back, and its fixed-point gain is the identity.
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 11);
  std::mt19937_64 rng(5);
  LidarStereoSettings settings = testSettings();
  settings.fine_gain_probe = 0.5;
  const LidarStereoResult r = solveLidarStereo(
      windowOf(kfs), perturb(rig.T_cam_lidar, randomPerturbation(0.01, 0.003, rng)), settings);
  ASSERT_TRUE(r.settled && r.covariance_known) << r.message;
  // In units of the trust limits; the probes' own jitter (the stereo noise at the pixels a face
  // lands on, over a 3-keyframe window) leaves a few tenths. A drive whose re-association feeds
  // back shows contractions of 0.5-0.95 and gains of 2-20.
  const Matrix6d scaled = inLimitUnits(r.fixed_point_gain, limitScale(0.1, 0.01));
  const double largest = (scaled - Matrix6d::Identity()).cwiseAbs().maxCoeff();
  std::printf("contraction %.3f, largest entry of gain - I (trust-limit units) %.3f\n",
              r.fixed_point_contraction, largest);
  EXPECT_GT(r.fixed_point_contraction, 0.0);
  EXPECT_LT(r.fixed_point_contraction, 0.3);
  EXPECT_LT(largest, 0.5);
}

TEST(LidarStereoSolver, CoarseStageKeepsToItsWindowBudget) {
  // The coarse stage samples at most coarse_faces_per_window faces over the window (and
  // coarse_faces_per_keyframe per keyframe): fewer associations, the same basin.
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 21);
  const std::vector<const Keyframe*> window = windowOf(kfs);
  LidarStereoSettings settings = testSettings();
  settings.run_fine = false;
  std::mt19937_64 rng(9);
  const Vector6d delta = randomPerturbation(3.0 / kDegPerRad, 0.3, rng);
  const LidarStereoResult full =
      solveLidarStereo(window, perturb(rig.T_cam_lidar, delta), settings);
  settings.coarse_faces_per_window = 900;
  const LidarStereoResult budget =
      solveLidarStereo(window, perturb(rig.T_cam_lidar, delta), settings);
  // 3 x 1500 faces sampled, a third of them in the image and associated; 900 with the budget.
  EXPECT_GT(full.coarse_inliers, 1000);
  EXPECT_LE(budget.coarse_inliers, 900);
  EXPECT_NEAR(double(budget.coarse_inliers) / full.coarse_inliers, 900.0 / 4500.0, 0.05);
  // Well inside the fine stage's basin: 0.05 deg / 0.5 cm with the full sample; with 300 faces
  // (about 100 per keyframe in the image) the coarse optimum moves more with which faces are
  // taken: 0.04-0.43 deg and 2-7 cm over 8 starts (2 sessions' samples), 0.35 deg / 3.5 cm here.
  const Vector6d e_full = poseError(full.T_after_coarse, rig.T_cam_lidar);
  EXPECT_LT(e_full.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(e_full.tail<3>().norm(), 0.01);
  const Vector6d e_budget = poseError(budget.T_after_coarse, rig.T_cam_lidar);
  EXPECT_LT(e_budget.head<3>().norm() * kDegPerRad, 0.5);
  EXPECT_LT(e_budget.tail<3>().norm(), 0.08);
}

TEST(LidarStereoSolver, EstimatesTheRightCameraYawOfTheClouds) {
  // Clouds rectified with a right camera 0.05 deg off in yaw (0.6 px of disparity): with the
  // yaw as a nuisance the solver finds it and the extrinsic; without, the optical axis absorbs it.
  const StereoRig rig = kittiLikeRig();
  const double yaw = 0.05 / kDegPerRad;
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 31, yaw);
  const std::vector<const Keyframe*> window = windowOf(kfs);
  std::mt19937_64 rng(7);
  const Eigen::Isometry3d T_init =
      perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  LidarStereoSettings s = testSettings();
  s.estimate_stereo_yaw = true;
  // Besides the yaw these disparities carry no common bias. The trust flags hold the yaw when they
  // propagate the model's 0.05 px disparity bias (a real matcher's is not uniform, so the yaw
  // need not absorb it), and against that this canyon's tz is loose (see the plane test above).
  const LidarStereoResult with_default_bias = solveLidarStereo(window, T_init, s);
  EXPECT_FALSE(with_default_bias.observable[5]) << "tz against the default 0.05 px bias";
  s.model_sigma_disparity_px = 0;
  const LidarStereoResult with = solveLidarStereo(window, T_init, s);
  const Vector6d e = poseError(with.T_cam_lidar, rig.T_cam_lidar);
  std::cout << "yaw estimate " << with.stereo_yaw_rad * kDegPerRad << " deg (true 0.05), error "
            << e.head<3>().norm() * kDegPerRad << " deg " << e.tail<3>().norm() * 100 << " cm\n";
  EXPECT_TRUE(with.converged) << with.message;
  EXPECT_NEAR(with.stereo_yaw_rad * kDegPerRad, 0.05, 0.005);
  EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(e.tail<3>().norm(), 0.01);

  s.estimate_stereo_yaw = false;
  const LidarStereoResult without = solveLidarStereo(window, T_init, s);
  const Vector6d e0 = poseError(without.T_cam_lidar, rig.T_cam_lidar);
  std::cout << "without the yaw: error " << e0.head<3>().norm() * kDegPerRad << " deg "
            << e0.tail<3>().norm() * 100 << " cm\n";
  EXPECT_EQ(without.stereo_yaw_rad, 0.0);
  EXPECT_GT(e0.tail<3>().norm(), 3 * e.tail<3>().norm());
  // A free yaw takes information from the pose: its covariance is the marginal one, larger
  // along the optical axis than with the yaw known.
  EXPECT_GT(with.covariance_model(5, 5), 1.2 * without.covariance_model(5, 5));
}

TEST(LidarStereoSolver, ANuisanceOnItsBoundOrBadSettingsAreNotConverged) {
  // The clouds 0.11 deg off in yaw with the yaw allowed 0.1 deg: the yaw stops on its bound, tz
  // 3.2 cm off at sigma 0.48 cm, which must not be declared converged. A bound of zero width makes
  // Ceres fail, which must not leave the start "settled" and converged; NaN settings must fail a
  // gate.
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 31, 0.11 / kDegPerRad);
  const std::vector<const Keyframe*> window = windowOf(kfs);
  LidarStereoSettings s = testSettings();
  s.estimate_stereo_yaw = true;
  s.max_stereo_yaw_deg = 0.1;
  const LidarStereoResult pinned = solveLidarStereo(window, rig.T_cam_lidar, s);
  EXPECT_NEAR(std::fabs(pinned.stereo_yaw_rad) * kDegPerRad, 0.1, 1e-6);
  EXPECT_FALSE(pinned.converged);
  EXPECT_NE(pinned.message.find("yaw ended on its bound"), std::string::npos) << pinned.message;
  s.max_stereo_yaw_deg = 1.0;
  const LidarStereoResult free_yaw = solveLidarStereo(window, rig.T_cam_lidar, s);
  EXPECT_NEAR(free_yaw.stereo_yaw_rad * kDegPerRad, 0.11, 0.01);
  for (double bad : {0.0, -1.0, std::nan("")}) {
    s.max_stereo_yaw_deg = bad;
    const LidarStereoResult r = solveLidarStereo(window, rig.T_cam_lidar, s);
    EXPECT_FALSE(r.converged) << bad;
    EXPECT_NE(r.message.find("max_stereo_yaw_deg > 0"), std::string::npos) << r.message;
  }
  s = testSettings();
  s.fine_gate_sigma = std::nan("");
  const LidarStereoResult nan_gate = solveLidarStereo(window, rig.T_cam_lidar, s);
  EXPECT_FALSE(nan_gate.converged);
  EXPECT_NE(nan_gate.message.find("positive numbers"), std::string::npos) << nan_gate.message;
}

TEST(LidarStereoSolver, ACancelledSolveIsNotConvergedWhereverItStops) {
  // The header's contract. (A cancel raised in the middle of the split-window check's fine stages
  // would leave the halves' starts and placeholder covariances, which must not pass as agreement;
  // that timing is not reproducible here, a cancel raised before the solve is.)
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 11);
  std::vector<Keyframe> more = canyonKeyframes(rig, 41);
  std::vector<const Keyframe*> window = windowOf(kfs);
  for (const auto& kf : more) window.push_back(&kf);  // 6 keyframes: halves of 3
  std::atomic<bool> cancel{true};
  LidarStereoSettings s = testSettings();
  s.cancel = &cancel;
  const LidarStereoResult r = solveLidarStereo(window, rig.T_cam_lidar, s);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.message, "cancelled");
  EXPECT_FALSE(r.halves.tested);
}

TEST(LidarStereoSolver, CoarseStageHoldsTheStereoNuisancesByDefault) {
  // The coarse stage only brings the pose into the fine stage's basin; the clouds' scale and yaw
  // are the fine stage's to estimate (a far start otherwise slides along the valley where the
  // forward offset, the scale and the yaw trade against each other).
  const StereoRig rig = kittiLikeRig();
  const std::vector<Keyframe> kfs = canyonKeyframes(rig, 31, 0.05 / kDegPerRad);
  std::mt19937_64 rng(7);
  const Eigen::Isometry3d T_init =
      perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  LidarStereoSettings s = testSettings();
  s.estimate_stereo_scale = s.estimate_stereo_yaw = true;
  s.run_fine = false;
  const LidarStereoResult held = solveLidarStereo(windowOf(kfs), T_init, s);
  EXPECT_EQ(held.stereo_scale, 1.0);
  EXPECT_EQ(held.stereo_yaw_rad, 0.0);
  s.coarse_estimates_stereo_nuisances = true;
  const LidarStereoResult freed = solveLidarStereo(windowOf(kfs), T_init, s);
  EXPECT_NE(freed.stereo_scale, 1.0);
  EXPECT_NE(freed.stereo_yaw_rad, 0.0);
  // Either way the fine stage then finds the yaw (0.05 deg) and the extrinsic.
  for (bool coarse_free : {false, true}) {
    s.coarse_estimates_stereo_nuisances = coarse_free;
    s.run_fine = true;
    const LidarStereoResult r = solveLidarStereo(windowOf(kfs), T_init, s);
    const Vector6d e = poseError(r.T_cam_lidar, rig.T_cam_lidar);
    EXPECT_NEAR(r.stereo_yaw_rad * kDegPerRad, 0.05, 0.01) << coarse_free;
    EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.1) << coarse_free;
    EXPECT_LT(e.tail<3>().norm(), 0.02) << coarse_free;
  }
}

TEST(LidarStereoSolver, MeasuresADisparityOffsetAndWidensTheCovarianceWithIt) {
  // Clouds rectified with a right camera 0.03 deg off in yaw: every disparity is short by
  // f yaw (1 + x_r^2), about 0.38 px, far beyond the model's 0.05 px common bias. The solver
  // (yaw not estimated) measures the offset from its residuals and widens the bias term with it;
  // on exact clouds the offset it measures is within the model and nothing changes.
  const StereoRig rig = kittiLikeRig();
  const double yaw = 0.03 / kDegPerRad;
  std::mt19937_64 rng(7);
  const Eigen::Isometry3d T_init =
      perturb(rig.T_cam_lidar, randomPerturbation(3.0 / kDegPerRad, 0.3, rng));
  LidarStereoSettings on = testSettings(), off = testSettings();
  off.measure_disparity_offset = false;
  on.check_window_halves = off.check_window_halves = false;  // the bias term alone

  const std::vector<Keyframe> shifted = canyonKeyframes(rig, 31, yaw);
  const LidarStereoResult a = solveLidarStereo(windowOf(shifted), T_init, on);
  const LidarStereoResult a_off = solveLidarStereo(windowOf(shifted), T_init, off);
  const double expected = rig.left.fx * yaw;  // at the image centre, more towards its sides
  std::printf("offset measured %.3f px (f yaw %.3f px); sigma tz %.2f cm, %.2f cm unmeasured\n",
              a.disparity_offset_px, expected, 100 * std::sqrt(a.covariance(5, 5)),
              100 * std::sqrt(a_off.covariance(5, 5)));
  EXPECT_GT(a.disparity_offset_px, expected);  // 0.46 px: (1 + x_r^2) averages 1.2 here
  EXPECT_LT(a.disparity_offset_px, 1.35 * expected);
  EXPECT_EQ(a_off.disparity_offset_px, 0.0);
  // The same estimate; the bias term grows by (offset / 0.05 px)^2 along its sensitivity.
  EXPECT_TRUE(a.T_cam_lidar.isApprox(a_off.T_cam_lidar, 1e-12));
  const Eigen::Matrix<double, 6, 1> h = a.bias_sensitivity.col(0);
  const Matrix6d added =
      (std::pow(a.disparity_offset_px, 2) - std::pow(on.model_sigma_disparity_px, 2)) * h *
      h.transpose();
  EXPECT_TRUE((a.covariance - a_off.covariance).isApprox(added, 1e-6));
  EXPECT_GT(a.covariance(5, 5), 4 * a_off.covariance(5, 5));
  EXPECT_TRUE(disparityOffsetWidensBias(a, on));
  EXPECT_DOUBLE_EQ(disparityBiasSigma(a, on), a.disparity_offset_px);

  const std::vector<Keyframe> exact = canyonKeyframes(rig, 31);
  const LidarStereoResult b = solveLidarStereo(windowOf(exact), T_init, on);
  const LidarStereoResult b_off = solveLidarStereo(windowOf(exact), T_init, off);
  std::printf("exact clouds: offset measured %.4f px\n", b.disparity_offset_px);
  EXPECT_LT(std::fabs(b.disparity_offset_px), 0.25 * on.model_sigma_disparity_px);
  EXPECT_TRUE(b.covariance.isApprox(b_off.covariance, 1e-12));
  EXPECT_FALSE(disparityOffsetWidensBias(b, on));
  EXPECT_DOUBLE_EQ(disparityBiasSigma(b, on), on.model_sigma_disparity_px);
  EXPECT_EQ(b.converged, b_off.converged);
}

TEST(LidarStereoSolver, FailsHonestlyWithoutStructure) {
  // Only the road: translation along camera x and z and rotation about y are unconstrained.
  const StereoRig rig = kittiLikeRig();
  const std::vector<Plane> road = {{Eigen::Vector3d(0, -1, 0), -1.65}};
  std::vector<Keyframe> kfs;
  for (int k = 0; k < 2; ++k) kfs.push_back(planeKeyframe(road, rig, 21 + k));
  std::vector<const Keyframe*> window{&kfs[0], &kfs[1]};
  std::mt19937_64 rng(9);
  const LidarStereoResult r = solveLidarStereo(
      window, perturb(rig.T_cam_lidar, randomPerturbation(1.0 / kDegPerRad, 0.1, rng)),
      testSettings());
  EXPECT_FALSE(r.converged);
  // ... because of the scene, and the message names its weakest direction.
  EXPECT_NE(r.message.find("does not constrain every axis"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("weakest direction"), std::string::npos) << r.message;
  std::cout << "road only: " << r.message << "; sigma";
  for (int i = 0; i < 6; ++i) std::cout << " " << std::sqrt(r.covariance(i, i));
  std::cout << "\n";
  EXPECT_FALSE(r.observable[1]);    // rotation about camera y
  EXPECT_FALSE(r.observable[3]);    // translation along camera x
  EXPECT_FALSE(r.observable[5]);    // translation along camera z
  EXPECT_TRUE(r.observable[4]);     // height above the road is constrained
  EXPECT_TRUE(r.covariance_known);  // weak axes are a covariance with large sigma, not none
}

// An unsettled fine stage that creeps steadily along tz (0.9 mm per update, as on a generated
// highway) is heading far beyond the 1 cm trust limit; one whose updates decay or alternate is not.
TEST(LidarStereoSolver, AnUnsettledCreepIsFlaggedAndADecayOrAnAlternationIsNot) {
  const LidarStereoSettings s;
  Vector6d step = Vector6d::Zero();
  step[5] = 0.0009;
  const std::vector<Vector6d> creep(12, step);
  const Vector6d drift = unsettledDrift(creep, s);
  EXPECT_GT(drift[5], 0.05);  // 6 updates summed plus 99 more at rho 0.99
  EXPECT_NEAR(drift.head<5>().norm(), 0.0, 1e-12);
  std::vector<Vector6d> decay, alternate;
  for (int i = 0; i < 12; ++i) {
    decay.push_back(step * std::pow(0.5, i));
    alternate.push_back(step * (i % 2 ? -1.0 : 1.0));
  }
  EXPECT_LT(unsettledDrift(decay, s)[5], 0.0001);  // 0.5^6 + ... of 0.9 mm, plus as much again
  EXPECT_NEAR(unsettledDrift(alternate, s)[5], 0.0, 1e-12);
  EXPECT_EQ(unsettledDrift({}, s), Vector6d::Zero());
}

// A creep of 0.45 mm per update along tz, its last update 0.29 mm (below the 0.3 mm settle limit,
// as on a generated residential drive of a random rig): at rho ~0.94 it still heads several
// millimetres on; a decay by half per update and an alternation head nowhere.
TEST(LidarStereoSolver, ASmallLastUpdateOfASteadyCreepStillWalks) {
  const LidarStereoSettings s;
  Vector6d step = Vector6d::Zero();
  step[5] = 0.00045;
  std::vector<Vector6d> creep(12, step), decay, alternate;
  creep.back()[5] = 0.00029;
  const double walk = walkAhead(creep, s);
  EXPECT_GT(walk, 0.25);  // in units of the 1 cm trust limit
  EXPECT_LT(walk, 1.0);
  for (int i = 0; i < 12; ++i) {
    decay.push_back(step * std::pow(0.5, i));
    alternate.push_back(step * (i % 2 ? -1.0 : 1.0));
  }
  EXPECT_LT(walkAhead(decay, s), 0.001);
  EXPECT_EQ(walkAhead(alternate, s), 0.0);
  EXPECT_EQ(walkAhead({step}, s), 0.0);
}

TEST(LidarStereoSolver, EmptyWindowIsNotConverged) {
  const LidarStereoResult r = solveLidarStereo({}, Eigen::Isometry3d::Identity());
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.message, "empty window");
  EXPECT_FALSE(r.covariance_known);  // its identity covariance is a placeholder
}

TEST(LidarStereoSolverReal, KittiWindowConvergesToOnePointFromPerturbations) {
  SKIP_WITHOUT_KITTI();
  const std::string base = tescalib_test::kittiDir() + "/sequences/";
  std::vector<Keyframe> kfs;
  StereoRig rig;
  for (const char* s : {"04", "05", "06", "07"}) {
    const KittiSequence seq(base + s);
    rig = seq.rig();
    for (size_t i : seq.keyframes(0.5))
      kfs.push_back(makeKeyframe(seq.load(i), rig, rig.T_cam_lidar, rig.T_right_left));
  }
  std::vector<const Keyframe*> window;
  for (const auto& kf : kfs) window.push_back(&kf);
  std::mt19937_64 rng(3);
  std::vector<Eigen::Isometry3d> estimates;
  for (int trial = 0; trial < 2; ++trial) {
    const Vector6d delta = randomPerturbation(3.0 / kDegPerRad, 0.3, rng);
    const LidarStereoResult r = solveLidarStereo(window, perturb(rig.T_cam_lidar, delta));
    const Vector6d e = poseError(r.T_cam_lidar, rig.T_cam_lidar);
    // Measured: 0.16 deg / 11 cm from KITTI's calibration on this 8-keyframe window (the
    // objective's optimum on these frames; see doc/limitations.md).
    EXPECT_LT(e.head<3>().norm() * kDegPerRad, 0.3);
    EXPECT_LT(e.tail<3>().norm(), 0.15);
    estimates.push_back(r.T_cam_lidar);
  }
  const Vector6d spread = poseError(estimates[0], estimates[1]);
  EXPECT_LT(spread.head<3>().norm() * kDegPerRad, 0.1);
  EXPECT_LT(spread.tail<3>().norm(), 0.02);
}
