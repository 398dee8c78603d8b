// How far the fine stage's fixed point moves for a given first step. The fine stage re-associates
// after every update: a LiDAR face is compared with the stereo point at its projection, and that
// point moves with T. Where moving T along a direction also moves the associations so that the
// residuals shrink (a wall seen at a grazing angle, depth edges), the next update goes on in the
// same direction, and the iteration settles farther than the first Gauss-Newton step: the map
// x_{k+1} = x_k + u(x_k) has the Jacobian M = I + du/dx at its fixed point, and a perturbation of
// the data that moves the first step by e moves the fixed point by (I - M)^-1 e. The covariance
// and the bias sensitivities of one Gauss-Newton step (the information at the end point) assume
// M = 0; this gain carries them to the fixed point.
#pragma once

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/solvers/lidar_stereo_association.h"

namespace tescalib {

struct LidarStereoEstimate;

/// The fine stage's fixed-point gain where it settled.
struct FixedPointGain {
  /// (I - M)^-1 over [phi; tau], with the clouds' scale and yaw re-estimated in every update as
  /// the fine stage does (where it estimates them); `gain_held` with them held at the estimate
  /// (what the held bias sensitivity takes).
  Matrix6d gain = Matrix6d::Identity(), gain_held = Matrix6d::Identity();
  double contraction = 0.0;  ///< spectral radius of M, the larger of the two (0: no feedback)
  bool determined = false;   ///< probes solved and the contraction below 1 (else the identity)
};

/// The fixed-point gain of the fine stage at `estimate` (where it settled), M = I + du/dx
/// measured by central differences: the updates from the estimate moved along each axis by plus
/// and minus fine_gain_probe times the trust limit (max_sigma_rot_deg, max_sigma_trans_m); twice
/// when the clouds' nuisances are estimated (free and held). Each update re-associates, so its
/// small-scale jitter (the stereo noise at the pixels a face lands on) enters M divided by the
/// probe: the probe is a sizeable fraction of the trust limit, and the gain keeps only M's
/// eigen-directions of magnitude fine_gain_noise_floor or more. Not determined when a probe
/// fails, or when M has an eigenvalue of magnitude 1 or more: the iteration does not contract
/// along some direction, and the window does not hold the fixed point.
FixedPointGain fineFixedPointGain(const ProjectiveAssociation& association,
                                  const LidarStereoSettings& settings,
                                  const LidarStereoEstimate& estimate);

}  // namespace tescalib
