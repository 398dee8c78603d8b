// How well a criterion pins its optimum down on a set of frames. The frames' scatter gives the
// sandwich covariance of an M-estimate, H^-1 (B / frames) H^-1, with H the mean score's Hessian
// and B the covariance of the frames' own gradients, both by finite differences of the settings'
// step (0.1 deg / 1 cm) about the optimum. It is far smaller than how far optima lie from the
// truth on generated drives: the frames of one drive share its scene, and each criterion has
// systematic errors of its own (SGBM at depth edges, occlusions, texture edges without a depth
// jump, the pair's and the LiDAR's errors). The criterion's model-error floor
// (ValidationSettings::optimum_floor) is added to it per axis. Directions along which the mean
// score does not curve towards the optimum are unresolved: the frames do not say where the
// optimum lies along them.
#pragma once

#include <array>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/validation/validation_set.h"

namespace tescalib {

struct OptimumUncertainty {
  /// Of the optimum [rad x3; m x3] (perturb()'s axes): the statistical one plus the floor's
  /// variance; only its resolved directions count (sigma, information).
  Matrix6d covariance = Matrix6d::Zero();
  /// The frames' scatter alone (the sandwich).
  Matrix6d statistical = Matrix6d::Zero();
  /// sqrt of the covariance's diagonal; infinity on axes an unresolved direction runs along.
  Vector6d sigma = Vector6d::Zero();
  std::array<bool, 6> resolved{};
  /// The number of resolved directions (the degrees of freedom of chi2()).
  int rank = 0;
  int frames = 0;

  /// (T - optimum)'s squared Mahalanobis distance over the resolved directions: chi2 with
  /// `rank` degrees of freedom when T is the point the optimum estimates.
  double chi2(const Eigen::Isometry3d& T_optimum, const Eigen::Isometry3d& T) const;

  /// The pseudo-inverse of the covariance restricted to the resolved directions (0 along the
  /// unresolved ones).
  Matrix6d information = Matrix6d::Zero();
};

/// The criterion's uncertainty about `T_optimum` (found by criterionOptimum()); 73 scorings of
/// the set. Needs at least 3 frames (with fewer, nothing is resolved).
OptimumUncertainty optimumUncertainty(ValidationSet& set, Criterion c,
                                      const Eigen::Isometry3d& T_optimum,
                                      const Eigen::Isometry3d& T_right_left);

}  // namespace tescalib
