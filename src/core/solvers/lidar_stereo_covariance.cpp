#include "tescalib/core/solvers/lidar_stereo_covariance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/LU>

#include "tescalib/core/uncertainty/common_bias.h"
#include "tescalib/core/uncertainty/sandwich_covariance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// The window-common biases' 1-sigma sizes, in the order of LidarStereoResult::bias_sensitivity's
/// columns.
std::vector<double> biasSigmas(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return {disparityBiasSigma(r, s),      s.model_sigma_range_m,
          s.model_sigma_disparity_scale, s.model_sigma_ground_disparity_px,
          groundTiltSigma(r, s),         s.model_sigma_lateral_disparity_px,
          s.model_sigma_lateral_tilt_px};
}

/// A per-axis floor for this window's f B (LidarStereoSettings::model_floor_focal_baseline_px_m).
std::array<double, 3> scaledFloor(std::array<double, 3> floor, const LidarStereoResult& r,
                                  const LidarStereoSettings& s) {
  const double factor = floorFocalBaselineFactor(r, s);
  for (double& v : floor) v *= factor;
  return floor;
}

/// What the fine residuals at the estimate tell about the parameters: the pose, then the clouds'
/// scale and yaw where they are estimated.
struct FineInformation {
  explicit FineInformation(int parameters)
      : H(Eigen::MatrixXd::Zero(parameters, parameters)),
        jtd(Eigen::MatrixXd::Zero(parameters, kLidarStereoBiases)) {}
  Eigen::MatrixXd H;                    ///< sum w J^T J
  std::vector<Eigen::VectorXd> scores;  ///< per cluster sum w r J
  /// The same per group of ring_cluster_rings rings and per cluster and group (empty without).
  std::vector<Eigen::VectorXd> ring_scores;
  std::vector<Eigen::MatrixXd> ring_information;  ///< per ring group sum w J^T J
  std::map<std::pair<int, int>, Eigen::VectorXd> cell_ring_scores;
  /// sum w J dr/db for the window-common biases: disparity offset (px), LiDAR range offset (m),
  /// disparity scale (relative: an error of f B), disparity offset of the ground alone (px), tilt
  /// of the ground's disparity across the image (px per unit of normalised column), disparity
  /// offset and tilt of the lateral surfaces (px, px per unit of normalised column).
  Eigen::MatrixXd jtd;
  double dtd = 0;                     ///< sum w D^2, D = dr / d(disparity offset)
  std::vector<double> offset_scores;  ///< per cluster sum w r D (with `scores`: the offset's share)
  double cost = 0;                    ///< mean Huber-weighted squared residual
};

/// Adds the rings' range offsets (LidarStereoEstimate::ring_offsets, 0 beyond it) to the
/// residual `r` (LidarRingOffsetResidual) and their columns, from `first`, to `J`.
void addRingOffsets(const LidarStereoAssociation& a, const std::vector<double>& offsets,
                    Eigen::Index first, double* r, Eigen::VectorXd* J) {
  J->tail(J->size() - first).setZero();
  if (a.ring < 0) return;
  const double gains[2] = {a.range_gain * a.lower_share, a.range_gain * (1.0 - a.lower_share)};
  for (int k = 0; k < 2; ++k) {
    const size_t ring = static_cast<size_t>(a.ring + k);
    if (ring < offsets.size()) *r -= gains[k] * offsets[ring] * a.inv_sigma;
    (*J)[first + ring] = -gains[k] * a.inv_sigma;
  }
}

/// The offsets' priors (ScalarPrior: what the data leave of a ring's offset is its prior) and
/// the prior on the mean of those the associations saw (RingOffsetMean).
void addRingOffsetPriors(const LidarStereoSettings& s, int first, int rings, Eigen::MatrixXd* H) {
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(H->rows());
  for (int i = first; i < first + rings; ++i) {
    if ((*H)(i, i) > 0) mean[i] = 1.0;
    (*H)(i, i) += std::pow(s.ring_range_sigma_m, -2);
  }
  if (mean.sum() == 0) return;
  mean /= mean.sum() * s.ring_range_mean_sigma_m;
  *H += mean * mean.transpose();
}

/// One fine residual at the estimate: r = (R n_l)^T (R p_l + t - p_s) / sigma, p_s as the clouds'
/// scale and yaw place it.
struct FineResidual {
  double r = 0;
  Eigen::Vector3d m, q;  ///< R n_l, R p_l
  Eigen::Vector3d ps;    ///< the corrected stereo point
  double dc = 0;         ///< the yaw-corrected disparity d + g yaw
};

/// The fine residual of `a` at the estimate and its Jacobian `J` over the pose and the estimated
/// scale and yaw.
FineResidual fineResidual(const LidarStereoAssociation& a, const LidarStereoEstimate& est,
                          const LidarStereoSettings& s, Eigen::VectorXd* J_out) {
  Eigen::VectorXd& J = *J_out;
  const int n_scale = s.estimate_stereo_scale ? 1 : 0;
  const Eigen::Isometry3d& T = est.T;
  FineResidual f;
  f.m = T.linear() * a.n_l, f.q = T.linear() * a.p_l;
  f.ps = correctedPoint(a, est.scale, est.yaw);
  f.r = f.m.dot(f.q + T.translation() - f.ps) * a.inv_sigma;
  J.head<3>() = f.m.cross(T.translation() - f.ps) * a.inv_sigma;
  J.segment<3>(3) = f.m * a.inv_sigma;
  // ps = scale d / (d + g yaw) p_s
  f.dc = a.d + a.g * est.yaw;
  const double mp = f.m.dot(a.p_s) * a.inv_sigma;
  if (n_scale) J[6] = -mp * a.d / f.dc;
  if (s.estimate_stereo_yaw) J[6 + n_scale] = mp * est.scale * a.d * a.g / (f.dc * f.dc);
  const Eigen::Index first = 6 + n_scale + (s.estimate_stereo_yaw ? 1 : 0);
  if (J.size() > first) addRingOffsets(a, est.ring_offsets, first, &f.r, &J);
  return f;
}

/// Adds an association's score w r J to its ring group's and its cluster and ring group's, and
/// its information w J J^T to its ring group's.
void addRingScore(const LidarStereoAssociation& a, const LidarStereoSettings& s, double w, double r,
                  const Eigen::VectorXd& J, FineInformation* info) {
  const int group = a.ring / s.ring_cluster_rings;
  const Eigen::Index n = J.size();
  if (static_cast<int>(info->ring_scores.size()) <= group) {
    info->ring_scores.resize(group + 1, Eigen::VectorXd::Zero(n));
    info->ring_information.resize(group + 1, Eigen::MatrixXd::Zero(n, n));
  }
  const Eigen::VectorXd g = w * r * J;
  info->ring_scores[group] += g;
  info->ring_information[group].noalias() += w * J * J.transpose();
  auto [it, fresh] = info->cell_ring_scores.try_emplace({a.cluster, group}, g);
  if (!fresh) it->second += g;
}

/// The ring groups' scores before the fit absorbed part of them: a group's residuals are fitted
/// by the same parameters, which leaves (I - H_g H^-1) of its own error in its score (H_g its
/// information). Few groups carry most of the information along some directions (the road's
/// rings for the camera's height and pitch), where the plain scores understate the spread; the
/// approximate jackknife (CR3: Bell and McCaffrey, 2002) undoes it, by at most 10x.
std::vector<Eigen::VectorXd> leverageAdjustedScores(const Eigen::MatrixXd& H_inv,
                                                    const FineInformation& info) {
  std::vector<Eigen::VectorXd> out = info.ring_scores;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(H_inv.rows(), H_inv.cols());
  for (size_t g = 0; g < out.size(); ++g) {
    const Eigen::VectorXd adjusted =
        (I - info.ring_information[g] * H_inv).fullPivLu().solve(info.ring_scores[g]);
    if (adjusted.allFinite() && adjusted.norm() <= 10.0 * info.ring_scores[g].norm())
      out[g] = adjusted;
  }
  return out;
}

/// The sandwich over image cells, and over rings too where the associations carry them.
Eigen::MatrixXd robustCovariance(const Eigen::MatrixXd& H_inv, const FineInformation& info,
                                 double residual_scale) {
  if (info.ring_scores.empty())
    return clusterRobustCovariance(H_inv, info.scores, residual_scale, 6);
  std::vector<Eigen::VectorXd> both;
  both.reserve(info.cell_ring_scores.size());
  for (const auto& [key, g] : info.cell_ring_scores) both.push_back(g);
  return twoWayClusterCovariance(H_inv, info.scores, leverageAdjustedScores(H_inv, info), both,
                                 residual_scale, 6);
}

/// Accumulates `info` over the fine associations (not empty) and sets the result's
/// keyframe_information and residual_scale.
void accumulateFineInformation(const LidarStereoEstimate& est, const LidarStereoSettings& s,
                               size_t window_size, FineInformation* info, LidarStereoResult* res) {
  const std::vector<LidarStereoAssociation>& as = est.fine_associations;
  const int n = static_cast<int>(info->H.rows());
  int n_clusters = 0;
  for (const auto& a0 : as) n_clusters = std::max(n_clusters, a0.cluster + 1);
  info->scores.assign(n_clusters, Eigen::VectorXd::Zero(n));
  info->offset_scores.assign(n_clusters, 0.0);
  res->keyframe_information.assign(window_size, Matrix6d::Zero());
  std::vector<double> abs_res;
  Eigen::VectorXd J(n);
  for (const auto& a0 : as) {
    const FineResidual f = fineResidual(a0, est, s, &J);
    const double r = f.r;
    const double w = std::fabs(r) <= s.fine_huber ? 1.0 : s.fine_huber / std::fabs(r);
    info->H += w * J * J.transpose();
    // ps ~ d / (d + delta): dr/d(delta) = m.ps / d_c; q = R p_l: dr/d(range) = m.R p_l / |p_l|.
    const double D = f.m.dot(f.ps) / f.dc * a0.inv_sigma;
    info->jtd.col(0) += w * J * D;
    info->dtd += w * D * D;
    info->offset_scores[a0.cluster] += w * r * D;
    info->jtd.col(1) += w * J * (f.m.dot(f.q) / a0.p_l.norm() * a0.inv_sigma);
    // d (1 + k): ps / (1 + k), dr/dk = m.ps.
    info->jtd.col(2) += w * J * (f.m.dot(f.ps) * a0.inv_sigma);
    // The ground's (columns 3 and 4) or the lateral surfaces' (5 and 6) offset and tilt.
    const int surface = onGround(f.m) ? 3 : onLateral(f.m) ? 5 : -1;
    if (surface > 0) {
      info->jtd.col(surface) += w * J * D;
      info->jtd.col(surface + 1) += w * J * (D * a0.p_s.x() / a0.p_s.z());
    }
    res->keyframe_information[a0.cluster / (s.cov_cells_x * s.cov_cells_y)] +=
        w * J.head<6>() * J.head<6>().transpose();
    info->scores[a0.cluster] += w * r * J;
    if (s.ring_cluster_rings > 0 && a0.ring >= 0) addRingScore(a0, s, w, r, J, info);
    info->cost += w * r * r;
    abs_res.push_back(std::fabs(r));
  }
  info->cost /= as.size();
  std::nth_element(abs_res.begin(), abs_res.begin() + abs_res.size() / 2, abs_res.end());
  res->residual_scale = 1.4826 * abs_res[abs_res.size() / 2];
}

/// The window-common disparity offset the fine residuals show (with the clouds' yaw estimated
/// the offset is a parameter already, and is not measured).
void measureDisparityOffset(const FineInformation& info, LidarStereoResult* res) {
  const CommonOffset offset = estimateCommonOffset(info.H, info.scores, info.jtd.col(0), info.dtd,
                                                   info.offset_scores, res->residual_scale);
  if (!offset.measured) return;
  res->disparity_offset_px = offset.value;
  res->disparity_offset_sigma_px = offset.sigma;
  if (std::getenv("TESCALIB_DEBUG"))
    std::fprintf(stderr, "disparity offset %+.4f px, sigma %.4f px\n", res->disparity_offset_px,
                 res->disparity_offset_sigma_px);
}

/// The covariances from an invertible information matrix, the pose's carried to the fine stage's
/// fixed point by its gains (lidar_stereo_fixed_point.h); returns whether every axis is
/// constrained.
bool covariancesFromInformation(const FineInformation& info, const FixedPointGain& fixed_point,
                                const LidarStereoSettings& s, LidarStereoResult* res) {
  const Matrix6d& gain = fixed_point.gain;
  const bool with_scale = s.estimate_stereo_scale;
  const Eigen::MatrixXd H_inv_full = info.H.inverse();
  const Matrix6d H_inv = H_inv_full.topLeftCorner<6, 6>();
  res->information = H_inv.inverse();  // the pose's marginal information
  res->covariance_known = true;
  res->covariance_model = H_inv;
  const Eigen::MatrixXd bias_moves = biasSensitivity(H_inv_full, info.jtd);  // pose and nuisances
  res->bias_sensitivity = gain * bias_moves.topRows<6>();
  if (info.H.rows() == 6)
    res->bias_sensitivity_held = res->bias_sensitivity;
  else
    res->bias_sensitivity_held = fixed_point.gain_held * heldBiasSensitivity(info.H, info.jtd);
  if (s.measure_disparity_offset && !s.estimate_stereo_yaw) measureDisparityOffset(info, res);
  const Eigen::MatrixXd robust = robustCovariance(H_inv_full, info, res->residual_scale);
  res->covariance = gain * robust.topLeftCorner<6, 6>() * gain.transpose();
  if (with_scale) {  // the common biases move the scale too
    res->stereo_scale_variance = robust(6, 6);
    res->stereo_scale_sensitivity = gain * H_inv_full.block<6, 1>(0, 6) / H_inv_full(6, 6);
    const std::vector<double> sigmas = biasSigmas(*res, s);
    for (size_t j = 0; j < sigmas.size(); ++j)
      res->stereo_scale_variance += std::pow(sigmas[j] * bias_moves(6, j), 2);
  }
  res->covariance_statistical = res->covariance;
  // Model error that more data does not average away (calibrated on generated drives, see
  // doc/method.md): common biases through this window's sensitivity to them, and a floor per axis.
  // What the window constrains is the statistical part and the common biases (a weakly
  // constrained axis is the one they move furthest: the highway's optical axis), without the
  // scene-independent floor.
  const Matrix6d constrained = constrainedCovariance(*res, s);
  const bool all_observable = trustFlags(constrained, s, res->observable);
  res->weak_directions = weakDirections(constrained, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  res->covariance = withLidarStereoBiases(*res, s, res->bias_sensitivity);
  addAxisVariances(&res->covariance, scaledFloor(s.model_sigma_rot_deg, *res, s),
                   scaledFloor(s.model_sigma_trans_m, *res, s));
  return all_observable;
}

}  // namespace

bool estimateLidarStereoCovariance(const LidarStereoEstimate& est, const LidarStereoSettings& s,
                                   size_t window_size, LidarStereoResult* res) {
  const int first = 6 + (s.estimate_stereo_scale ? 1 : 0) + (s.estimate_stereo_yaw ? 1 : 0);
  const int rings =
      s.ring_range_sigma_m > 0 ? static_cast<int>(ringOffsetCount(est.fine_associations)) : 0;
  FineInformation info(first + rings);
  if (!est.fine_associations.empty()) accumulateFineInformation(est, s, window_size, &info, res);
  if (rings > 0) addRingOffsetPriors(s, first, rings, &info.H);
  res->final_cost = info.cost;
  if (est.fine_associations.empty()) return false;
  if (!informationInvertible(info.H)) {
    res->information = info.H.topLeftCorner<6, 6>();
    res->covariance = res->covariance_model = res->covariance_statistical =
        Matrix6d::Identity() * 1e6;
    return false;
  }
  res->fixed_point_gain = est.fixed_point.gain;
  res->fixed_point_contraction = est.fixed_point.contraction;
  return covariancesFromInformation(info, est.fixed_point, s, res);
}

double floorFocalBaselineFactor(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return r.focal_baseline_px_m > 0 ? s.model_floor_focal_baseline_px_m / r.focal_baseline_px_m
                                   : 1.0;
}

bool onGround(const Eigen::Vector3d& normal) { return std::fabs(normal.y()) > 0.8 * normal.norm(); }

bool onLateral(const Eigen::Vector3d& normal) {
  return !onGround(normal) && std::fabs(normal.x()) > 0.7 * normal.norm();
}

double groundTiltSigma(const LidarStereoResult& r, const LidarStereoSettings& s) {
  const double per_deg = r.vertical_low_pass_px >= s.model_ground_tilt_low_pass_px
                             ? s.model_sigma_ground_tilt_low_passed_px_per_deg
                             : s.model_sigma_ground_tilt_px_per_deg;
  return per_deg * std::fabs(r.rectification_roll_deg);
}

Matrix6d withLidarStereoBiases(const LidarStereoResult& r, const LidarStereoSettings& s,
                               const LidarStereoBiasSensitivity& h) {
  return withCommonBiases(r.covariance_statistical, h, biasSigmas(r, s));
}

Matrix6d constrainedCovariance(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return withLidarStereoBiases(r, s, r.bias_sensitivity_held);
}

}  // namespace tescalib
