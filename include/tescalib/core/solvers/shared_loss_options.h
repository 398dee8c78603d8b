// Options of the solvers' Ceres problems, whose residual blocks share one robust loss function.
#pragma once

#include <ceres/problem.h>

namespace tescalib {

/// A problem that owns its cost functions but not the loss function its residual blocks share
/// (the caller keeps that one alive for the problem's lifetime).
inline ceres::Problem::Options sharedLossProblemOptions() {
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return po;
}

}  // namespace tescalib
