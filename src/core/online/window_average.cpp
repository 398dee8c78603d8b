#include "tescalib/core/online/window_average.h"

#include <algorithm>

#include <Eigen/Cholesky>

namespace tescalib {

Eigen::Isometry3d weightedMeanPose(const std::vector<Eigen::Isometry3d>& poses,
                                   const std::vector<Matrix6d>& weights) {
  Eigen::Isometry3d mean = poses.back();
  for (int iteration = 0; iteration < 5; ++iteration) {
    Matrix6d information = Matrix6d::Zero();
    Vector6d pull = Vector6d::Zero();
    for (size_t i = 0; i < poses.size(); ++i) {
      information += weights[i];
      pull += weights[i] * poseError(poses[i], mean);
    }
    const Vector6d step = information.ldlt().solve(pull);
    mean = perturb(mean, step);
    if (step.norm() < 1e-12) break;
  }
  return mean;
}

bool WindowAverage::windowOf(const OnlineEstimate& e, double share, Window* w) {
  const auto weight = [share](const Matrix6d& cov, Matrix6d* out) {
    const Eigen::LLT<Matrix6d> llt(cov);
    if (!cov.allFinite() || llt.info() != Eigen::Success) return false;
    *out = share * llt.solve(Matrix6d::Identity());
    return true;
  };
  w->T_cam_lidar = e.T_cam_lidar;
  w->T_right_left = e.T_right_left;
  w->stereo_estimated = e.stereo_estimated;
  w->weight_stereo = Matrix6d::Zero();
  return weight(e.cov_lidar, &w->weight_lidar) &&
         (!e.stereo_estimated || weight(e.cov_stereo, &w->weight_stereo));
}

void WindowAverage::restart(const OnlineEstimate& e, double share) {
  windows_.clear();
  Window w;
  if (capacity_ > 1 && windowOf(e, std::max(share, 1e-3), &w)) windows_.push_back(w);
}

OnlineEstimate WindowAverage::add(const OnlineEstimate& e, double share) {
  Window w;
  // A window whose stereo part is not like the others' (estimated or not) starts again.
  if (!windowOf(e, std::max(share, 1e-3), &w) || windows_.empty() ||
      windows_.back().stereo_estimated != e.stereo_estimated) {
    restart(e, share);
    return e;
  }
  windows_.push_back(w);
  while (static_cast<int>(windows_.size()) > capacity_) windows_.pop_front();
  std::vector<Eigen::Isometry3d> lidar, stereo;
  std::vector<Matrix6d> lidar_weights, stereo_weights;
  for (const Window& x : windows_) {
    lidar.push_back(x.T_cam_lidar);
    lidar_weights.push_back(x.weight_lidar);
    stereo.push_back(x.T_right_left);
    stereo_weights.push_back(x.weight_stereo);
  }
  OnlineEstimate mean = e;
  mean.T_cam_lidar = weightedMeanPose(lidar, lidar_weights);
  if (e.stereo_estimated) mean.T_right_left = weightedMeanPose(stereo, stereo_weights);
  mean.windows_averaged = static_cast<int>(windows_.size());
  return mean;
}

}  // namespace tescalib
