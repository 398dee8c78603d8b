#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/overlay.h"
#include "tescalib/core/uncertainty/trust.h"

using namespace tescalib;

TEST(Geometry, ExpLogRoundTrip) {
  const Eigen::Vector3d phi(0.1, -0.2, 0.3);
  EXPECT_LT((logSO3(expSO3(phi)) - phi).norm(), 1e-12);
  EXPECT_LT((expSO3(Eigen::Vector3d::Zero()) - Eigen::Matrix3d::Identity()).norm(), 1e-15);
  // Exp is the rotation by |phi| about phi (not its transpose, which a matching Log would hide).
  const Eigen::Matrix3d R = Eigen::AngleAxisd(phi.norm(), phi.normalized()).toRotationMatrix();
  EXPECT_LT((expSO3(phi) - R).norm(), 1e-12);
  // 90 deg about z takes x to y.
  EXPECT_LT((expSO3(Eigen::Vector3d(0, 0, M_PI / 2)) * Eigen::Vector3d::UnitX() -
             Eigen::Vector3d::UnitY())
                .norm(),
            1e-12);
}

TEST(Geometry, PerturbationFollowsTheDocumentedConvention) {
  // geometry.h and the evaluation contract: R = Exp(phi) R_ref (phi in the target frame, on the
  // left), t = t_ref + tau; poseError(a, b) = [Log(R_a R_b^T); t_a - t_b].
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.3, -0.1, 2.0);
  Vector6d d;
  d << 0.02, -0.05, 0.01, 0.1, -0.2, 0.05;
  const Eigen::Isometry3d P = perturb(T, d);
  const Eigen::Matrix3d R_d =
      Eigen::AngleAxisd(d.head<3>().norm(), d.head<3>().normalized()).toRotationMatrix();
  EXPECT_LT((P.linear() - R_d * T.linear()).norm(), 1e-12);
  EXPECT_LT((P.translation() - (T.translation() + d.tail<3>())).norm(), 1e-15);
  // On the right it would differ by far more than the tolerance above.
  EXPECT_GT((R_d * T.linear() - T.linear() * R_d).norm(), 1e-3);
  const Vector6d e = poseError(P, T);
  const Eigen::AngleAxisd aa(P.linear() * T.linear().transpose());
  EXPECT_LT((e.head<3>() - aa.angle() * aa.axis()).norm(), 1e-12);
  EXPECT_LT((e.tail<3>() - (P.translation() - T.translation())).norm(), 1e-15);
}

TEST(Geometry, PerturbationHasExactSizeAndErrorRecoversIt) {
  std::mt19937_64 rng(7);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  T.translation() = Eigen::Vector3d(0.3, -0.1, 2.0);
  for (int i = 0; i < 20; ++i) {
    const Vector6d d = randomPerturbation(3.0 / kDegPerRad, 0.3, rng);
    EXPECT_NEAR(d.head<3>().norm() * kDegPerRad, 3.0, 1e-9);
    EXPECT_NEAR(d.tail<3>().norm(), 0.3, 1e-12);
    const Vector6d e = poseError(perturb(T, d), T);
    EXPECT_LT((e - d).norm(), 1e-9);
  }
}

TEST(Geometry, NeesByHandAndWithoutAPositiveDefiniteCovariance) {
  // e = (1, 0, 0, 0, 0, 2), P = diag(3, 1, 1, 1, 1, 1) with P(0,5) = P(5,0) = 1:
  // P^-1 e solves 3x + y = 1, x + y = 2 -> x = -0.5, y = 2.5; e . P^-1 e = -0.5 + 5 = 4.5.
  Vector6d e = Vector6d::Zero();
  e(0) = 1, e(5) = 2;
  Matrix6d P = Matrix6d::Identity();
  P(0, 0) = 3, P(0, 5) = P(5, 0) = 1;
  EXPECT_NEAR(nees(e, P), 4.5, 1e-12);
  P(5, 5) = 0.2;  // indefinite (3 * 0.2 < 1): no NEES
  EXPECT_TRUE(std::isnan(nees(e, P)));
  EXPECT_TRUE(std::isnan(nees(e, Matrix6d::Constant(std::nan("")))));
}

TEST(Geometry, NeesIgnoringADirectionIsTheOtherAxesMarginalNees) {
  // The same e and P: ignoring tz leaves rx alone, whose marginal variance is 3 (1 / 3); ignoring
  // rx leaves tz, variance 1 (4). Ignoring the direction of e itself leaves nothing; ignoring
  // nothing is nees(). The length of an ignored direction does not matter.
  Vector6d e = Vector6d::Zero();
  e(0) = 1, e(5) = 2;
  Matrix6d P = Matrix6d::Identity();
  P(0, 0) = 3, P(0, 5) = P(5, 0) = 1;
  const Vector6d tz = Vector6d::Unit(5), rx = Vector6d::Unit(0);
  EXPECT_NEAR(neesIgnoring(e, P, {tz}), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(neesIgnoring(e, P, {0.01 * rx}), 4.0, 1e-12);
  EXPECT_NEAR(neesIgnoring(e, P, {e}), 0.0, 1e-12);
  EXPECT_NEAR(neesIgnoring(e, P, {}), 4.5, 1e-12);
  EXPECT_NEAR(neesIgnoring(e, P, {tz, 2 * tz}), 1.0 / 3.0, 1e-9);  // a repeated direction
  P(5, 5) = 0.2;
  EXPECT_TRUE(std::isnan(neesIgnoring(e, P, {tz})));
}

TEST(Geometry, BeyondLimitsGivesTheLooseDirectionsInPoseUnits) {
  // Limits 0.1 deg and 1 cm; sigma 2 cm along tz, 0.05 deg about rx: only tz is beyond, as
  // (0, 0, 0, 0, 0, 0.01) (the unit direction in units of the limits, back in metres).
  Matrix6d P = Matrix6d::Identity() * 1e-12;
  P(5, 5) = 0.02 * 0.02;
  P(0, 0) = std::pow(0.05 / kDegPerRad, 2);
  const std::vector<Vector6d> out = beyondLimits(weakDirections(P, 0.1, 0.01), 0.1, 0.01);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0](5), 0.01, 1e-12);
  EXPECT_NEAR(out[0].head<5>().norm(), 0.0, 1e-12);
}

TEST(Geometry, WeakDirectionsFindACoupledDirectionNoAxisShows) {
  // Limits 0.1 deg and 1 cm. In units of the limits the covariance is 0.25 I plus 1.75 along
  // v = (tz - tx) / sqrt(2): the eigenvalue along v is 2 (ratio sqrt(2)), every other one 0.25
  // (ratio 0.5). Per axis tx and tz have 0.25 + 1.75 / 2 = 1.125 (sigma 1.06x the limit); with
  // 1.35 instead of 1.75 both axes are within the limits (0.925), the direction is not (1.28x).
  const double rot = 0.1 / kDegPerRad, trans = 0.01;
  Vector6d scale;
  scale << rot, rot, rot, trans, trans, trans;
  Vector6d v = Vector6d::Zero();
  v(3) = -1 / std::sqrt(2.0), v(5) = 1 / std::sqrt(2.0);
  for (const double along : {1.75, 1.35}) {
    const Matrix6d scaled = 0.25 * Matrix6d::Identity() + along * v * v.transpose();
    const Matrix6d cov = scale.asDiagonal() * scaled * scale.asDiagonal();
    const std::vector<WeakDirection> weak = weakDirections(cov, 0.1, 0.01);
    ASSERT_EQ(weak.size(), 6u);
    EXPECT_NEAR(weak[0].ratio, std::sqrt(0.25 + along), 1e-9);
    for (int i = 1; i < 6; ++i) EXPECT_NEAR(weak[i].ratio, 0.5, 1e-9);
    // Unit, and the sign convention: the largest component positive (tx and tz tie here).
    EXPECT_NEAR(std::fabs(weak[0].direction.dot(v)), 1.0, 1e-9);
    EXPECT_NEAR(weak[0].direction.norm(), 1.0, 1e-12);
    bool trusted[6];
    EXPECT_EQ(axesWithin(cov, 0.1, 0.01, trusted), along < 1.5);
  }
  Vector6d d = Vector6d::Zero();
  d(5) = 0.93, d(3) = -0.34, d(1) = 0.12;  // ry under 0.2: left out
  EXPECT_EQ(describeDirection(d), "0.93 tz - 0.34 tx");
  d(1) = 0.25;
  EXPECT_EQ(describeDirection(d), "0.93 tz - 0.34 tx + 0.25 ry");
  EXPECT_TRUE(weakDirections(Matrix6d::Constant(std::nan("")), 0.1, 0.01).empty());
  // The clause a solver's message ends with: nothing without a covariance.
  EXPECT_EQ(weakestClause({}), "");
  WeakDirection w;
  w.ratio = 2.0, w.direction(5) = 1.0;
  EXPECT_EQ(weakestClause({w}), "; weakest direction 1.00 tz, 2.00x the trust limit");
}

TEST(Geometry, WeakDirectionsNeedPositiveLimitsAndLongRatiosAreWhole) {
  // A limit of 0 must not give six directions of ratio 0 ("none computed" read as computed),
  // and a ratio of 1e16 must not be cut off in the message.
  const Matrix6d cov = Matrix6d::Identity() * 1e-4;
  EXPECT_TRUE(weakDirections(cov, 0.0, 0.01).empty());
  EXPECT_TRUE(weakDirections(cov, 0.05, -1.0).empty());
  EXPECT_EQ(weakDirections(cov, 0.05, 0.01).size(), 6u);
  WeakDirection w;
  w.ratio = 1e20;
  w.direction(5) = 1.0;
  EXPECT_EQ(describeWeakest(w), "1.00 tz, 1e+20x the trust limit");
  w.ratio = 1.744;
  EXPECT_EQ(describeWeakest(w), "1.00 tz, 1.74x the trust limit");
}

TEST(Overlay, StatusTextOnADarkBand) {
  cv::Mat img(120, 400, CV_8UC3, cv::Scalar(200, 200, 200));
  drawStatusText({"LiDAR->left: converged", "left->right: converged"}, &img);
  // Two lines: a band of 2 x 18 + 6 = 42 rows, darkened, with white text in it.
  cv::Mat band = img(cv::Rect(0, 0, 400, 42)), below = img(cv::Rect(0, 42, 400, 78));
  double lo, hi;
  cv::minMaxLoc(band.reshape(1), &lo, &hi);
  EXPECT_LT(lo, 80.0);   // darkened: 200 x 0.35 = 70
  EXPECT_GT(hi, 240.0);  // text
  cv::minMaxLoc(below.reshape(1), &lo, &hi);
  EXPECT_EQ(lo, 200.0);  // untouched
  EXPECT_EQ(hi, 200.0);
}

TEST(Overlay, NonFinitePointsTransformsAndDepthsDrawNothing) {
  // A NaN point passes a plain depth test (NaN compares false), rounds to pixel (0, 0) and would
  // index the colour map with INT_MIN (a segfault in the optimised build).
  CameraIntrinsics cam;
  cam.fx = cam.fy = 100, cam.cx = 50, cam.cy = 40, cam.width = 100, cam.height = 80;
  LidarPoint in_view, nan_point;
  in_view.z = 10.f;
  nan_point.x = nan_point.y = nan_point.z = std::nanf("");
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d bad = I;
  bad.translation().x() = std::nan("");
  cv::Mat img(80, 100, CV_8UC3, cv::Scalar::all(0));
  EXPECT_EQ(drawLidarOverlay({nan_point, in_view}, I, cam, &img, 80.0), 1);
  EXPECT_EQ(drawLidarOverlay({in_view}, bad, cam, &img, 80.0), 0);
  EXPECT_EQ(drawLidarOverlay({in_view}, I, cam, &img, std::nan("")), 0);
  LidarPoint far_off;  // projects to about x = 1e9: outside, not an int overflow
  far_off.x = 1e8f, far_off.z = 1.5f;
  EXPECT_EQ(drawLidarOverlay({far_off}, I, cam, &img, 80.0), 0);
}
