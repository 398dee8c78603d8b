#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tescalib/core/geometry.h"
#include "tescalib/core/overlay.h"

using namespace tescalib;

TEST(Geometry, ExpLogRoundTrip) {
  const Eigen::Vector3d phi(0.1, -0.2, 0.3);
  EXPECT_LT((logSO3(expSO3(phi)) - phi).norm(), 1e-12);
  EXPECT_LT((expSO3(Eigen::Vector3d::Zero()) - Eigen::Matrix3d::Identity()).norm(), 1e-15);
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
