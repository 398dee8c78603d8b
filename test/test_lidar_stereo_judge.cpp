// The wide-basin search's check for a second minimum (refuseBesideRivalMinimum): a converged
// solve is refused when another start settled elsewhere and fits the window as well.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/lidar_stereo_judge.h"

using namespace tescalib;

namespace {

/// A settled solve at tz_m along the optical axis with sigmas 0.02 deg / 4 mm per axis.
LidarStereoResult solve(double tz_m, double cost, bool converged) {
  LidarStereoResult r;
  Vector6d d = Vector6d::Zero();
  d(5) = tz_m;
  r.T_cam_lidar = perturb(Eigen::Isometry3d::Identity(), d);
  Vector6d sigma;
  sigma << 0.02 / kDegPerRad, 0.02 / kDegPerRad, 0.02 / kDegPerRad, 0.004, 0.004, 0.004;
  r.covariance = sigma.array().square().matrix().asDiagonal();
  r.covariance_statistical = r.covariance;
  r.covariance_known = true;
  r.bias_sensitivity_held.setZero();
  r.settled = true;
  r.converged = converged;
  for (bool& o : r.observable) o = converged;
  r.fine_inliers = 20000;
  r.final_cost = cost;
  return r;
}

/// The search's choice, `tried[chosen]`, after the check.
LidarStereoResult judged(const std::vector<LidarStereoResult>& tried, int chosen) {
  LidarStereoResult r = tried[chosen];
  refuseBesideRivalMinimum(tried, LidarStereoSettings(), &r);
  return r;
}

}  // namespace

TEST(SearchRivalMinimum, ASettledStartFarAwayThatFitsBetterRefusesTheChosenOne) {
  // The generated urban window's case: the solve from the initial guess settles (refused by
  // another check) with cost 0.33, a turned start converges 96 cm further along z with 0.56.
  const std::vector<LidarStereoResult> tried = {solve(0.0, 0.33, false), solve(0.96, 0.56, true)};
  const LidarStereoResult r = judged(tried, 1);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("more than one minimum"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("96.0 cm away"), std::string::npos) << r.message;
  // Widened along the difference: tz's sigma is now about the 96 cm between the two.
  EXPECT_NEAR(std::sqrt(r.covariance(5, 5)), 0.96, 0.01);
  EXPECT_NEAR(std::sqrt(r.covariance(3, 3)), 0.004, 1e-9);
  EXPECT_FALSE(r.observable[5]);
}

TEST(SearchRivalMinimum, AStartThatFitsClearlyWorseOrSettlesNearbyOrDidNotSettleLeavesItAlone) {
  const LidarStereoResult chosen = solve(0.0, 0.33, true);
  LidarStereoResult unsettled = solve(0.96, 0.30, false);
  unsettled.settled = false;
  const std::vector<std::vector<LidarStereoResult>> cases = {
      {chosen, solve(0.96, 0.40, false)},   // 21 % worse
      {chosen, solve(0.012, 0.30, false)},  // 1.2 cm away: chi2 4.5 with the summed covariances
      {chosen, unsettled},                  // still moving: not a minimum
      {chosen}};
  for (const auto& tried : cases) {
    const LidarStereoResult r = judged(tried, 0);
    EXPECT_TRUE(r.converged) << r.message;
    EXPECT_TRUE(r.message.empty()) << r.message;
    EXPECT_DOUBLE_EQ(r.covariance(5, 5), chosen.covariance(5, 5));
  }
}

TEST(SearchRivalMinimum, TwoConvergedStartsApartThatFitAlikeAreRefused) {
  // Within 10 % of the chosen one's residual counts as fitting as well.
  const std::vector<LidarStereoResult> tried = {solve(0.0, 0.35, true), solve(0.05, 0.33, true)};
  const LidarStereoResult r = judged(tried, 0);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("5.0 cm away"), std::string::npos) << r.message;
}

TEST(HalvesStartsApart, AHalfThatSettlesElsewhereFromTheInitialGuessIsFarAndOneThatFailedIsNot) {
  // The generated highway window's case: from the estimate a half settles at tz 0.43 m, from the
  // initial guess at 0.55 m, both converged with sigmas of 4 mm: chi2 450 along z.
  const LidarStereoResult from_estimate[2] = {solve(0.43, 0.3, true), solve(0.42, 0.3, true)};
  LidarStereoResult rechecked[2] = {solve(0.43, 0.3, true), solve(0.55, 0.3, true)};
  Vector6d difference = Vector6d::Zero();
  const double c = halvesStartsApart(from_estimate, rechecked, &difference);
  EXPECT_NEAR(c, 0.13 * 0.13 / (2 * 0.004 * 0.004), 1e-6);
  EXPECT_NEAR(difference(5), 0.13, 1e-9);
  // Failing only for an unconstrained axis (a highway's tz) still counts.
  rechecked[1].converged = false;
  rechecked[1].only_unconstrained = true;
  EXPECT_NEAR(halvesStartsApart(from_estimate, rechecked, &difference), c, 1e-9);
  // Unsettled, or a nuisance on its bound: no minimum, no evidence.
  rechecked[1].only_unconstrained = false;
  EXPECT_NEAR(halvesStartsApart(from_estimate, rechecked, &difference), 0.0, 1e-9);
  // Both where they were: the halves have one minimum.
  const LidarStereoResult same[2] = {from_estimate[0], from_estimate[1]};
  EXPECT_NEAR(halvesStartsApart(from_estimate, same, &difference), 0.0, 1e-12);
}
