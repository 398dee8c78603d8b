#include "tescalib/core/solvers/lidar_stereo_fixed_point.h"

#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "tescalib/core/solvers/lidar_stereo_update.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// One fine-stage update from T with the clouds' nuisances of `est` (copied: the probe does not
/// move them).
Vector6d probeUpdate(const ProjectiveAssociation& association, const LidarStereoSettings& s,
                     const LidarStereoEstimate& est, const Eigen::Isometry3d& T) {
  double scale = est.scale, yaw = est.yaw;
  std::vector<double> rings = est.ring_offsets;
  const std::vector<LidarStereoAssociation> as = association.associate(T, scale, yaw);
  if (static_cast<int>(as.size()) < s.min_inliers)
    return Vector6d::Constant(std::numeric_limits<double>::quiet_NaN());
  return solveLidarStereoUpdate(as, T.translation(), LidarStereoObjective::kPointPointNormal, s,
                                s.fine_huber, &scale, &yaw,
                                s.ring_range_sigma_m > 0 ? &rings : nullptr);
}

/// The iteration's Jacobian M = I + du/dx by central differences along each axis, or nothing
/// when a probe fails.
std::optional<Matrix6d> iterationJacobian(const ProjectiveAssociation& association,
                                          const LidarStereoSettings& s,
                                          const LidarStereoEstimate& est) {
  const Vector6d step =
      s.fine_gain_probe * limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m).cwiseInverse();
  Matrix6d M;
  for (int i = 0; i < 6; ++i) {
    const Vector6d e = Vector6d::Unit(i) * step[i];
    const Vector6d up = probeUpdate(association, s, est, perturb(est.T, e));
    const Vector6d um = probeUpdate(association, s, est, perturb(est.T, -e));
    if (!up.allFinite() || !um.allFinite()) return std::nullopt;
    M.col(i) = Vector6d::Unit(i) + (up - um) / (2 * step[i]);
  }
  return M;
}

void printGain(const char* what, const Matrix6d& gain, double contraction,
               const LidarStereoSettings& s) {
  const Matrix6d scaled = inLimitUnits(gain, limitScale(s.max_sigma_rot_deg, s.max_sigma_trans_m));
  std::fprintf(stderr, "fine fixed point%s: contraction %.3f, gain (trust-limit units)\n", what,
               contraction);
  for (int i = 0; i < 6; ++i)
    std::fprintf(stderr, "  %7.3f %7.3f %7.3f %7.3f %7.3f %7.3f\n", scaled(i, 0), scaled(i, 1),
                 scaled(i, 2), scaled(i, 3), scaled(i, 4), scaled(i, 5));
}

/// M without its eigen-directions of magnitude below `floor` (the probes' jitter; a complex pair
/// shares its magnitude, so what is kept stays real).
Matrix6d significantPart(const Matrix6d& M, double floor) {
  const Eigen::EigenSolver<Matrix6d> es(M);
  Eigen::Matrix<std::complex<double>, 6, 1> lambda = es.eigenvalues();
  for (int k = 0; k < 6; ++k)
    if (std::abs(lambda[k]) < floor) lambda[k] = 0.0;
  const Eigen::Matrix<std::complex<double>, 6, 6> V = es.eigenvectors();
  return (V * lambda.asDiagonal() * V.inverse()).real();
}

/// (I - M)^-1 of M's significant part and M's spectral radius, or nothing when a probe failed;
/// the identity when M does not contract.
std::optional<std::pair<Matrix6d, double>> gainOf(const std::optional<Matrix6d>& M,
                                                  const LidarStereoSettings& s) {
  if (!M) return std::nullopt;
  const double contraction = M->eigenvalues().cwiseAbs().maxCoeff();
  if (!(contraction < 1.0)) return std::make_pair(Matrix6d::Identity().eval(), contraction);
  const Matrix6d kept = significantPart(*M, s.fine_gain_noise_floor);
  return std::make_pair(Matrix6d((Matrix6d::Identity() - kept).inverse()), contraction);
}

}  // namespace

FixedPointGain fineFixedPointGain(const ProjectiveAssociation& association,
                                  const LidarStereoSettings& s, const LidarStereoEstimate& est) {
  FixedPointGain out;
  const auto free = gainOf(iterationJacobian(association, s, est), s);
  if (!free) return out;
  out.contraction = free->second;
  if (!(out.contraction < 1.0)) return out;
  out.gain = out.gain_held = free->first;
  if (s.estimate_stereo_scale || s.estimate_stereo_yaw) {
    LidarStereoSettings held = s;
    held.estimate_stereo_scale = held.estimate_stereo_yaw = false;
    const auto h = gainOf(iterationJacobian(association, held, est), s);
    if (!h) return out;
    out.contraction = std::max(out.contraction, h->second);
    if (!(out.contraction < 1.0)) return out;
    out.gain_held = h->first;
  }
  out.determined = true;
  if (std::getenv("TESCALIB_DEBUG")) {
    printGain("", out.gain, free->second, s);
    printGain(" (nuisances held)", out.gain_held, out.contraction, s);
  }
  return out;
}

}  // namespace tescalib
