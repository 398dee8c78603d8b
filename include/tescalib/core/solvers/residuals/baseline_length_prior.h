// The stiff prior that keeps the left-right baseline at a given length while its direction and
// the rotation stay free (PhotometricSettings::fix_baseline_length).
#pragma once

#include <ceres/ceres.h>
#include <Eigen/Core>

namespace tescalib {

/// Weight of the stiff baseline-length prior: residual units per metre (1 per 0.1 mm).
constexpr double kBaselineLengthWeight = 1e4;

/// Stiff prior |t_ref + tau| = length (units: 0.1 mm) on delta = [phi; tau] of T_right_left.
struct BaselineLengthPrior {
  BaselineLengthPrior(const Eigen::Vector3d& t_ref, double length)
      : t_ref_(t_ref), length_(length) {}
  template <typename T>
  bool operator()(const T* const delta, T* residual) const {
    T n2 = T(0);
    for (int i = 0; i < 3; ++i) n2 += (T(t_ref_[i]) + delta[3 + i]) * (T(t_ref_[i]) + delta[3 + i]);
    residual[0] = (ceres::sqrt(n2) - T(length_)) * T(kBaselineLengthWeight);
    return true;
  }
  Eigen::Vector3d t_ref_;
  double length_;
};

}  // namespace tescalib
