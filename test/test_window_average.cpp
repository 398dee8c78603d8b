// The published estimate's average of fresh windows (window_average.h): the weighted mean pose,
// the capacity, the new-keyframe share and the covariance it keeps.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/online/window_average.h"

using namespace tescalib;

namespace {

Eigen::Isometry3d pose(double rx_deg, double tz_m) {
  Vector6d d = Vector6d::Zero();
  d(0) = rx_deg / kDegPerRad;
  d(5) = tz_m;
  return perturb(Eigen::Isometry3d::Identity(), d);
}

OnlineEstimate estimate(double rx_deg, double tz_m, double sigma_scale = 1.0) {
  OnlineEstimate e;
  e.T_cam_lidar = pose(rx_deg, tz_m);
  Vector6d sigma;
  sigma << 0.02 / kDegPerRad, 0.02 / kDegPerRad, 0.02 / kDegPerRad, 0.005, 0.005, 0.005;
  e.cov_lidar = (sigma * sigma_scale).array().square().matrix().asDiagonal();
  e.converged = true;
  return e;
}

Vector6d errorOf(const Eigen::Isometry3d& T, double rx_deg, double tz_m) {
  return poseError(T, pose(rx_deg, tz_m));
}

}  // namespace

TEST(WindowAverage, EqualWeightsGiveTheMidpointAndUnequalOnesLeanToTheInformed) {
  const std::vector<Eigen::Isometry3d> poses = {pose(0.1, 0.02), pose(-0.1, 0.0)};
  const Matrix6d I = Matrix6d::Identity();
  EXPECT_LT(errorOf(weightedMeanPose(poses, {I, I}), 0.0, 0.01).norm(), 1e-9);
  // Three times the information on the first: three quarters of the way to it.
  EXPECT_LT(errorOf(weightedMeanPose(poses, {3 * I, I}), 0.05, 0.015).norm(), 1e-9);
}

TEST(WindowAverage, AveragesUpToItsCapacityAndKeepsTheNewestCovariance) {
  WindowAverage average(2);
  average.restart(estimate(0.04, 0.0));
  OnlineEstimate e = average.add(estimate(0.0, 0.004), 1.0);
  EXPECT_EQ(e.windows_averaged, 2);
  EXPECT_LT(errorOf(e.T_cam_lidar, 0.02, 0.002).norm(), 1e-9);
  // A less certain window (sigma x2, a quarter of the information) counts for less, and the
  // oldest window leaves: the mean of the last two only.
  e = average.add(estimate(0.05, 0.0, 2.0), 1.0);
  EXPECT_EQ(e.windows_averaged, 2);
  EXPECT_LT(errorOf(e.T_cam_lidar, 0.01, 0.0032).norm(), 1e-9);
  EXPECT_TRUE(e.cov_lidar.isApprox(estimate(0.05, 0.0, 2.0).cov_lidar));
}

TEST(WindowAverage, AWindowWeighsWithItsShareOfNewKeyframes) {
  WindowAverage average(8);
  average.restart(estimate(0.0, 0.0));
  // Half of its keyframes new: half the information of a window of its covariance.
  const OnlineEstimate e = average.add(estimate(0.03, 0.0), 0.5);
  EXPECT_LT(errorOf(e.T_cam_lidar, 0.01, 0.0).norm(), 1e-9);
}

TEST(WindowAverage, ACovarianceThatCannotBeInvertedStartsAgain) {
  WindowAverage average(8);
  average.restart(estimate(0.0, 0.0));
  OnlineEstimate bad = estimate(0.05, 0.0);
  bad.cov_lidar(0, 0) = std::nan("");
  const OnlineEstimate e = average.add(bad, 1.0);
  EXPECT_EQ(e.windows_averaged, 1);
  EXPECT_EQ(average.size(), 0u);
  EXPECT_LT(errorOf(e.T_cam_lidar, 0.05, 0.0).norm(), 1e-9);
}
