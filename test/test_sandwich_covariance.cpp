#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/uncertainty/sandwich_covariance.h"

namespace tescalib {
namespace {

Eigen::VectorXd scalar(double v) { return Eigen::VectorXd::Constant(1, v); }

/// Mean of (error^2 / variance) over repeated draws of a mean estimated from rings x cells x 5
/// observations whose errors share one offset per ring (sigma 0.5) besides their own (sigma 1):
/// the variances from clustering by cell alone, and by cell and ring.
struct NeesOfBoth {
  double cells = 0, two_way = 0;
};

NeesOfBoth neesOfSharedRingOffsets(int draws) {
  const int rings = 20, cells = 24, per = 5, n = rings * cells * per;
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  NeesOfBoth out;
  for (int k = 0; k < draws; ++k) {
    std::vector<double> offset(rings);
    for (double& u : offset) u = 0.5 * normal(rng);
    std::vector<double> y(n);
    double mean = 0;
    for (int i = 0; i < n; ++i) mean += (y[i] = offset[i / (cells * per)] + normal(rng)) / n;
    std::vector<Eigen::VectorXd> by_cell(cells, scalar(0)), by_ring(rings, scalar(0)),
        by_both(rings * cells, scalar(0));
    for (int i = 0; i < n; ++i) {
      const int ring = i / (cells * per), cell = (i / per) % cells;
      by_cell[cell][0] += y[i] - mean, by_ring[ring][0] += y[i] - mean;
      by_both[ring * cells + cell][0] += y[i] - mean;
    }
    const Eigen::MatrixXd H_inv = Eigen::MatrixXd::Constant(1, 1, 1.0 / n);
    const double e2 = mean * mean;
    out.cells += e2 / clusterRobustCovariance(H_inv, by_cell, 0.0, 1)(0, 0) / draws;
    out.two_way +=
        e2 / twoWayClusterCovariance(H_inv, by_cell, by_ring, by_both, 0.0, 1)(0, 0) / draws;
  }
  return out;
}

}  // namespace

TEST(SandwichCovariance, ClusteringBothWaysCoversAnErrorSharedAlongRings) {
  const NeesOfBoth nees = neesOfSharedRingOffsets(300);
  // Each cell holds every ring alike: its score sees none of the ring offsets, which make up
  // 97 % of the estimate's variance. Clustered both ways the mean NEES is about 1 (1 DoF; with
  // 20 rings its expectation is a little above 1).
  EXPECT_GT(nees.cells, 10.0);
  EXPECT_GT(nees.two_way, 0.7);
  EXPECT_LT(nees.two_way, 1.5);
}

TEST(SandwichCovariance, TwoWayEqualsOneWayWhenTheSecondKindIsSingletons) {
  // Two cells of two observations; the second kind and the intersections each observation alone.
  const std::vector<Eigen::VectorXd> cells = {scalar(3), scalar(-1)};
  const std::vector<Eigen::VectorXd> singles = {scalar(1), scalar(2), scalar(-2), scalar(1)};
  const Eigen::MatrixXd H_inv = Eigen::MatrixXd::Constant(1, 1, 0.5);
  // M = 2 (9 + 1) = 20 (two clusters: 2/1); H^-1 M H^-1 = 5.
  EXPECT_NEAR(clusterRobustCovariance(H_inv, cells, 0.0, 1)(0, 0), 5.0, 1e-12);
  EXPECT_NEAR(twoWayClusterCovariance(H_inv, cells, singles, singles, 0.0, 1)(0, 0), 5.0, 1e-12);
}

TEST(SandwichCovariance, ANegativeDifferenceIsClippedAndThenFloored) {
  // M = 0.01 + 0.01 - 2 (1 + 1) < 0: clipped to 0, below the floor 0.5^2 x 2 = 0.5.
  const Eigen::MatrixXd H_inv = Eigen::MatrixXd::Constant(1, 1, 2.0);
  const std::vector<Eigen::VectorXd> small = {scalar(0.1)}, both = {scalar(1), scalar(1)};
  EXPECT_NEAR(twoWayClusterCovariance(H_inv, small, small, both, 0.5, 1)(0, 0), 0.5, 1e-12);
  // Without a floor the clipped covariance is zero, not negative.
  EXPECT_NEAR(twoWayClusterCovariance(H_inv, small, small, both, 0.0, 0)(0, 0), 0.0, 1e-12);
}

}  // namespace tescalib
