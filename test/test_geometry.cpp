#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tescalib/core/geometry.h"

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
