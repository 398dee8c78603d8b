#include "tescalib/core/solvers/lidar_stereo_fine.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/solvers/lidar_stereo_fixed_point.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// Projective re-association makes the last updates wiggle at the 0.1 mm level: settled means
/// well below the noise, not exactly still.
bool belowSettleLimits(const Vector6d& x, const LidarStereoSettings& s) {
  return x.head<3>().norm() * kDegPerRad < s.fine_settle_rot_deg &&
         x.tail<3>().norm() < s.fine_settle_trans_m;
}

void printUpdate(int it, size_t associations, const Vector6d& d, double scale, double yaw) {
  std::fprintf(stderr,
               "fine it %d: %zu assoc, update %.5f deg %.5f m (rot [%.5f %.5f %.5f] deg, "
               "t [%.5f %.5f %.5f] m), scale %.5f, yaw %.5f deg\n",
               it, associations, d.head<3>().norm() * kDegPerRad, d.tail<3>().norm(),
               d[0] * kDegPerRad, d[1] * kDegPerRad, d[2] * kDegPerRad, d[3], d[4], d[5], scale,
               yaw * kDegPerRad);
}

/// The direction (in units of the trust limits, `scale`) of the last half of `updates` summed
/// (`sum`), and the ratio rho of successive updates along it, clipped to [0, 0.99].
double creepRatio(const std::vector<Vector6d>& updates, const Vector6d& scale, const Vector6d& sum,
                  Vector6d* dir) {
  *dir = sum.cwiseProduct(scale).normalized();
  double num = 0, den = 0;
  for (size_t i = updates.size() / 2; i + 1 < updates.size(); ++i) {
    const double a = dir->dot(updates[i].cwiseProduct(scale));
    num += a * dir->dot(updates[i + 1].cwiseProduct(scale)), den += a * a;
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.99) : 0.0;
}

/// The last half of `updates` summed.
Vector6d lastHalfSum(const std::vector<Vector6d>& updates) {
  Vector6d sum = Vector6d::Zero();
  for (size_t i = updates.size() / 2; i < updates.size(); ++i) sum += updates[i];
  return sum;
}

/// What a creep along the last updates' direction would still add (the geometric series of the
/// last update with ratio rho), as [phi; tau]; nothing for fewer than two updates or no net move
/// (`sum`: lastHalfSum).
Vector6d creepAhead(const std::vector<Vector6d>& updates, const Vector6d& scale,
                    const Vector6d& sum) {
  if (updates.size() < 2 || !(sum.norm() > 0)) return Vector6d::Zero();
  Vector6d dir;
  const double rho = creepRatio(updates, scale, sum, &dir);
  const double last = dir.dot(updates.back().cwiseProduct(scale));
  return std::max(last, 0.0) * rho / (1 - rho) * dir.cwiseQuotient(scale);
}

}  // namespace

Vector6d unsettledDrift(const std::vector<Vector6d>& updates, const LidarStereoSettings& s) {
  const Vector6d sum = lastHalfSum(updates);
  return sum + creepAhead(updates, limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m), sum);
}

double walkAhead(const std::vector<Vector6d>& updates, const LidarStereoSettings& s) {
  const Vector6d scale = limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m);
  return creepAhead(updates, scale, lastHalfSum(updates)).cwiseProduct(scale).norm();
}

bool runFineStage(const std::vector<const Keyframe*>& window, const LidarStereoSettings& s,
                  LidarStereoEstimate* est, LidarStereoResult* res) {
  const ProjectiveAssociation association(window, s);
  std::vector<LidarStereoAssociation>& as = est->fine_associations;
  constexpr double kCycleOfLimits = 0.1;
  const Vector6d limit = limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m);
  Vector6d d_prev = Vector6d::Zero();
  std::vector<Vector6d> updates;
  for (int it = 0; it < s.fine_reassociations; ++it) {
    if (s.cancelled()) {
      res->message = "cancelled";
      return false;
    }
    ++res->iterations;
    as = association.associate(est->T, est->scale, est->yaw);
    res->fine_inliers = static_cast<int>(as.size());
    if (static_cast<int>(as.size()) < s.min_inliers) break;
    const Vector6d d = solveLidarStereoUpdate(
        as, est->T.translation(), LidarStereoObjective::kPointPointNormal, s, s.fine_huber,
        &est->scale, &est->yaw, s.ring_range_sigma_m > 0 ? &est->ring_offsets : nullptr);
    if (!d.allFinite()) {
      est->solver_failed = true;
      break;
    }
    if (std::getenv("TESCALIB_DEBUG")) printUpdate(it, as.size(), d, est->scale, est->yaw);
    est->T = perturb(est->T, d);
    updates.push_back(d);
    if (belowSettleLimits(d, s) && !(walkAhead(updates, s) > s.fine_settle_walk)) {
      est->settled = true;
      break;
    }
    // Re-association can alternate between two association sets (a 2-cycle, seen with the
    // stereo scale and yaw free, and with the stereo surface's derivative on windows of a few
    // keyframes): then the net move over the last two updates is what must be small, and the
    // midpoint is kept, within half the cycle of either end (at most kCycleOfLimits of the
    // trust limits: well inside any covariance that passes them).
    if (it > 0 && belowSettleLimits(d + d_prev, s) &&
        0.5 * d.cwiseProduct(limit).norm() < kCycleOfLimits) {
      est->T = perturb(est->T, -0.5 * d);
      est->settled = true;
      break;
    }
    d_prev = d;
  }
  est->fine_drift = est->settled ? Vector6d::Zero() : unsettledDrift(updates, s);
  if (est->settled && s.fine_gain_probe > 0)
    est->fixed_point = fineFixedPointGain(association, s, *est);
  return true;
}

}  // namespace tescalib
