#include "tescalib/core/solvers/lidar_stereo_coarse.h"

#include "tescalib/core/solvers/lidar_stereo_association.h"

namespace tescalib {
namespace {

bool smallUpdate(const Vector6d& d, const LidarStereoSettings& s) {
  return d.head<3>().norm() * kDegPerRad < s.converge_rot_deg &&
         d.tail<3>().norm() < s.converge_trans_m;
}

}  // namespace

bool runCoarseStage(const std::vector<const Keyframe*>& window, const LidarStereoSettings& s,
                    LidarStereoEstimate* est, LidarStereoResult* res) {
  const NormalSpaceAssociation association(window, s);
  for (double gate : s.coarse_gates) {
    if (est->solver_failed) break;  // the result is not converged: no later gate, no fine stage
    for (int it = 0; it < s.coarse_reassociations; ++it) {
      if (s.cancelled()) {
        res->message = "cancelled";
        return false;
      }
      ++res->iterations;
      const std::vector<LidarStereoAssociation> as =
          association.associate(est->T, est->scale, gate);
      res->coarse_inliers = static_cast<int>(as.size());
      if (static_cast<int>(as.size()) < s.min_inliers) break;
      const Vector6d d =
          solveLidarStereoUpdate(as, est->T.translation(), LidarStereoObjective::kPointPlaneNormal,
                                 s, s.coarse_loss_scale, &est->scale, &est->yaw);
      if (!d.allFinite()) {
        est->solver_failed = true;
        break;
      }
      est->T = perturb(est->T, d);
      if (smallUpdate(d, s)) break;
    }
  }
  return true;
}

}  // namespace tescalib
