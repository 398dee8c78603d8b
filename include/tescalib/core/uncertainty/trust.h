// Reading a 6-DoF covariance over [phi; tau] (rad, m): NEES, per-axis trust against sigma limits,
// and the weak directions of the paper's uncertainty analysis.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tescalib/core/common/geometry.h"

namespace tescalib {

/// Normalised estimation error squared e^T P^-1 e of an error over [phi; tau] under its
/// covariance (6 DoF: mean 6 over many estimates when the covariance tells the truth); NaN when
/// the covariance is not positive definite (an estimate without one has no NEES).
double nees(const Vector6d& error, const Matrix6d& covariance);

/// nees() with no information along `ignored` (directions over [phi; tau], any length): the
/// error's components along them count for nothing, as with an infinite variance there, so
/// only what the covariance constrains is compared (6 minus their number DoF). NaN as nees().
double neesIgnoring(const Vector6d& error, const Matrix6d& covariance,
                    const std::vector<Vector6d>& ignored);

/// Adds independent per-axis variances to a covariance over [phi; tau]: 1-sigma rotations (deg)
/// and translations (m) about / along the camera axes (the solvers' model-error floors).
void addAxisVariances(Matrix6d* covariance, const std::array<double, 3>& sigma_rot_deg,
                      const std::array<double, 3>& sigma_trans_m);

/// Per-axis trust flags from a covariance over [phi; tau] (rad, m): an axis is trusted when its
/// sigma is below `max_sigma_rot_deg` (rotation) or `max_sigma_trans_m` (translation); returns
/// true when every axis is.
bool axesWithin(const Matrix6d& covariance, double max_sigma_rot_deg, double max_sigma_trans_m,
                bool trusted[6]);

/// A direction of a covariance over [phi; tau] measured against the trust limits. In units of
/// the limits (rotations divided by `max_sigma_rot_deg`, translations by `max_sigma_trans_m`) the
/// covariance has eigenvalue `ratio`^2 along `direction`. A ratio above 1: the data leave that
/// combination of axes looser than the limits, even when each axis on its own is within them.
struct WeakDirection {
  double ratio = 0;                       ///< 1 sigma along the direction over the limit
  Vector6d direction = Vector6d::Zero();  ///< unit, limit-scaled; its largest component > 0
};

/// The per-axis factors that take [phi; tau] (rad, m) into units of the trust limits (rotations
/// over `max_sigma_rot_deg`, translations over `max_sigma_trans_m`).
Vector6d limitScale(double max_sigma_rot_deg, double max_sigma_trans_m);

/// A linear map of [phi; tau] displacements (a gain, a Jacobian) with its input and output in
/// units of the trust limits: diag(scale) map diag(scale)^-1, `scale` from limitScale.
Matrix6d inLimitUnits(const Matrix6d& map, const Vector6d& scale);

/// A displacement `v` already in units of the limits as a weak direction: ratio |v|, direction
/// v / |v| with its largest component positive (ratio 0 and no direction when v is zero).
WeakDirection weakDirectionAlong(const Vector6d& v);

/// The six eigen-directions of `covariance` in units of the limits, the weakest first (the
/// degeneracy of the paper's uncertainty analysis, in directions rather than axes). Empty when
/// the covariance is not finite or a limit is not positive.
std::vector<WeakDirection> weakDirections(const Matrix6d& covariance, double max_sigma_rot_deg,
                                          double max_sigma_trans_m);

/// The directions of a weakDirections list (made with these limits) that are beyond the limits
/// (ratio above 1), back over [phi; tau] (rad, m).
std::vector<Vector6d> beyondLimits(const std::vector<WeakDirection>& directions,
                                   double max_sigma_rot_deg, double max_sigma_trans_m);

/// A direction in words, its components of at least 0.2 largest first: "0.93 tz - 0.34 ry".
std::string describeDirection(const Vector6d& direction);

/// A weak direction in words with its ratio: "0.93 tz - 0.34 tx, 1.74x the trust limit" ("" when
/// its ratio is 0: none computed).
std::string describeWeakest(const WeakDirection& weakest);

/// "; weakest direction 0.93 tz - 0.34 tx, 1.74x the trust limit" for the first of a
/// weakDirections list, to end a solver's message ("" when the list is empty).
std::string weakestClause(const std::vector<WeakDirection>& directions);

/// The first (weakest) of weakDirections' list; ratio 0 when it is empty.
inline WeakDirection weakestOf(const std::vector<WeakDirection>& directions) {
  return directions.empty() ? WeakDirection() : directions.front();
}

/// The names of the axes not trusted, "rx ry rz tx ty tz" order, space-separated ("" when none).
std::string untrustedAxes(const bool trusted[6]);

}  // namespace tescalib
