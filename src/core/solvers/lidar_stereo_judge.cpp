// Widening a LiDAR-stereo solve's covariance and judging its axes again, and the wide-basin
// search's check for a second minimum (lidar_stereo_judge.h).
#include "tescalib/core/solvers/lidar_stereo_judge.h"

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

void widenAndJudge(double k, const Matrix6d& added, bool refuse, const std::string& why,
                   const LidarStereoSettings& s, LidarStereoResult* full) {
  const Matrix6d constrained = k * constrainedCovariance(*full, s) + added;
  full->covariance = k * full->covariance + added;
  full->covariance_statistical = k * full->covariance_statistical + added;
  full->stereo_scale_variance *= k;
  full->weak_directions = weakDirections(constrained, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  const bool all_trusted = trustFlags(constrained, s, full->observable);
  if (!full->converged || (all_trusted && !refuse)) return;
  full->converged = false;
  full->message = why + weakestClause(full->weak_directions);
}

namespace {

/// chi2 (6 DoF) of the difference between two solves' estimates with their summed covariances
/// (`b`'s only when it has one).
double chi2Between(const LidarStereoResult& a, const LidarStereoResult& b) {
  const Vector6d e = poseError(b.T_cam_lidar, a.T_cam_lidar);
  const Matrix6d S = b.covariance_known ? Matrix6d(a.covariance + b.covariance) : a.covariance;
  return e.dot(S.ldlt().solve(e));
}

}  // namespace

double halvesStartsApart(const LidarStereoResult from_estimate[2],
                         const LidarStereoResult rechecked[2], Vector6d* difference) {
  double worst = 0;
  for (int h = 0; h < 2; ++h) {
    if (!rechecked[h].converged && !rechecked[h].only_unconstrained) continue;
    const double c = chi2Between(from_estimate[h], rechecked[h]);
    if (!(c <= worst))
      worst = c, *difference = poseError(rechecked[h].T_cam_lidar, from_estimate[h].T_cam_lidar);
  }
  return worst;
}

namespace {

/// How much worse (mean normalised fine residual) a settled solve elsewhere may fit the window
/// and still count as a minimum as likely as the chosen one.
constexpr double kRivalCostRatio = 1.1;

/// A solve among `tried` that settled where `best` is not (beyond halves_chi2_limit with their
/// covariances; `best` itself, among them, is 0 away) and fits the window about as well: a second
/// minimum the window does not tell from `best`'s. Null when there is none.
const LidarStereoResult* rivalMinimum(const LidarStereoResult& best,
                                      const std::vector<LidarStereoResult>& tried,
                                      const LidarStereoSettings& s, double* chi2) {
  for (const LidarStereoResult& r : tried) {
    if (!r.settled || r.fine_inliers < s.min_inliers) continue;
    if (!(r.final_cost <= kRivalCostRatio * best.final_cost)) continue;
    const double c = chi2Between(best, r);
    if (c > s.halves_chi2_limit) return *chi2 = c, &r;
  }
  return nullptr;
}

}  // namespace

void refuseBesideRivalMinimum(const std::vector<LidarStereoResult>& tried,
                              const LidarStereoSettings& s, LidarStereoResult* chosen) {
  double c = 0;
  const LidarStereoResult* rival = rivalMinimum(*chosen, tried, s, &c);
  if (!rival) return;
  const Vector6d e = poseError(rival->T_cam_lidar, chosen->T_cam_lidar);
  const Eigen::Vector3d dt = rival->T_cam_lidar.translation() - chosen->T_cam_lidar.translation();
  widenAndJudge(
      1.0, e * e.transpose(), true,
      formatted("another start settles %.2f deg / %.1f cm away (chi2 %.1f > %.1f, 6 "
                "DoF) and fits the window as well or better (mean normalised residual %.3f, this "
                "one %.3f): the window holds more than one minimum",
                e.head<3>().norm() * kDegPerRad, 100 * dt.norm(), c, s.halves_chi2_limit,
                rival->final_cost, chosen->final_cost),
      s, chosen);
}

}  // namespace tescalib
