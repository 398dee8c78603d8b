#include "tescalib/core/solvers/lidar_stereo_update.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>

#include <ceres/ceres.h>

#include "tescalib/core/solvers/residuals/lidar_normal_residual.h"
#include "tescalib/core/solvers/residuals/lidar_ring_offset_residual.h"
#include "tescalib/core/solvers/residuals/point_plane_normal_residual.h"
#include "tescalib/core/solvers/residuals/scalar_prior.h"
#include "tescalib/core/solvers/shared_loss_options.h"

namespace tescalib {
namespace {

/// Bounds the clouds' scale and yaw where this stage estimates them, holds them constant
/// otherwise.
void boundStereoNuisances(bool coarse, const LidarStereoSettings& s, double* scale, double* yaw,
                          ceres::Problem* problem) {
  const bool nuisances = !coarse || s.coarse_estimates_stereo_nuisances;
  if (s.estimate_stereo_scale && nuisances) {
    problem->SetParameterLowerBound(scale, 0, 1.0 / s.max_stereo_scale);
    problem->SetParameterUpperBound(scale, 0, s.max_stereo_scale);
  } else {
    problem->SetParameterBlockConstant(scale);
  }
  if (s.estimate_stereo_yaw && nuisances) {
    const double limit = s.max_stereo_yaw_deg / kDegPerRad;
    problem->SetParameterLowerBound(yaw, 0, -limit);
    problem->SetParameterUpperBound(yaw, 0, limit);
  } else {
    problem->SetParameterBlockConstant(yaw);
  }
}

/// The coarse stage's residuals or the fine stage's (without ring offsets).
void addResiduals(const std::vector<LidarStereoAssociation>& as, const Eigen::Vector3d& t_ref,
                  bool coarse, const LidarStereoSettings& s, ceres::LossFunction* loss,
                  double* delta, double* scale, double* yaw, ceres::Problem* problem) {
  for (const auto& a : as) {
    if (coarse) {
      problem->AddResidualBlock(
          PointPlaneNormalResidual::Create(a.q, a.m, t_ref, a.p_s, a.n_s, a.inv_sigma,
                                           s.normal_residual_weight, a.d, a.g),
          loss, delta, scale, yaw);
    } else {
      problem->AddResidualBlock(
          LidarNormalResidual::Create(a.q, a.m, t_ref, a.p_s, a.inv_sigma, a.d, a.g), loss, delta,
          scale, yaw);
    }
  }
}

/// The fine residuals with their rings' range offsets, and each used ring's prior.
void addRingOffsetResiduals(const std::vector<LidarStereoAssociation>& as,
                            const Eigen::Vector3d& t_ref, const LidarStereoSettings& s,
                            ceres::LossFunction* loss, double* delta, double* scale, double* yaw,
                            std::vector<double>* offsets, ceres::Problem* problem) {
  offsets->resize(std::max(offsets->size(), ringOffsetCount(as)), 0.0);
  std::vector<bool> used(offsets->size(), false);
  for (const auto& a : as) {
    if (a.ring < 0) {
      problem->AddResidualBlock(
          LidarNormalResidual::Create(a.q, a.m, t_ref, a.p_s, a.inv_sigma, a.d, a.g), loss, delta,
          scale, yaw);
      continue;
    }
    problem->AddResidualBlock(LidarRingOffsetResidual::Create(a, t_ref), loss, delta, scale, yaw,
                              &(*offsets)[a.ring], &(*offsets)[a.ring + 1]);
    used[a.ring] = used[a.ring + 1] = true;
  }
  std::vector<double*> used_blocks;
  for (size_t r = 0; r < used.size(); ++r) {
    if (!used[r]) continue;
    problem->AddResidualBlock(ScalarPrior::Create(s.ring_range_sigma_m), nullptr, &(*offsets)[r]);
    used_blocks.push_back(&(*offsets)[r]);
  }
  if (!used_blocks.empty())
    problem->AddResidualBlock(
        new RingOffsetMean(static_cast<int>(used_blocks.size()), s.ring_range_mean_sigma_m),
        nullptr, used_blocks);
}

}  // namespace

Vector6d solveLidarStereoUpdate(const std::vector<LidarStereoAssociation>& as,
                                const Eigen::Vector3d& t_ref, LidarStereoObjective objective,
                                const LidarStereoSettings& s, double loss_scale, double* scale,
                                double* yaw, std::vector<double>* ring_offsets) {
  const bool coarse = objective == LidarStereoObjective::kPointPlaneNormal;
  double delta[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem problem(sharedLossProblemOptions());
  std::unique_ptr<ceres::LossFunction> loss;
  if (coarse)
    loss = std::make_unique<ceres::CauchyLoss>(loss_scale);
  else
    loss = std::make_unique<ceres::HuberLoss>(loss_scale);
  const std::vector<double> offsets_before = ring_offsets ? *ring_offsets : std::vector<double>();
  const bool with_offsets = !coarse && ring_offsets;
  if (with_offsets)
    addRingOffsetResiduals(as, t_ref, s, loss.get(), delta, scale, yaw, ring_offsets, &problem);
  else
    addResiduals(as, t_ref, coarse, s, loss.get(), delta, scale, yaw, &problem);
  if (!as.empty()) boundStereoNuisances(coarse, s, scale, yaw, &problem);
  ceres::Solver::Options opt;
  // The rings' offsets make the normal equations mostly sparse: a residual sees the pose, the
  // clouds' scale and yaw and two of 64 offsets.
  opt.linear_solver_type =
      with_offsets ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::DENSE_NORMAL_CHOLESKY;
  opt.max_num_iterations = s.ceres_iterations;
  opt.num_threads = s.threads;
  opt.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const double scale_before = *scale, yaw_before = *yaw;
  ceres::Solve(opt, &problem, &summary);
  if (std::getenv("TESCALIB_DEBUG")) std::fprintf(stderr, "%s\n", summary.BriefReport().c_str());
  Vector6d d;
  // A failed solve leaves delta at 0, which the stages would take for "settled" at the start:
  // NaN tells them it failed.
  if (!summary.IsSolutionUsable()) {
    *scale = scale_before, *yaw = yaw_before;
    if (ring_offsets) *ring_offsets = offsets_before;
    return Vector6d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  for (int i = 0; i < 6; ++i) d[i] = delta[i];
  return d;
}

}  // namespace tescalib
