#include "tescalib/core/solvers/lidar_stereo_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

#include <ceres/ceres.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_representation.h>
#include <pcl/point_types.h>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/residuals/lidar_normal_residual.h"
#include "tescalib/core/solvers/residuals/point_plane_normal_residual.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

using Clock = std::chrono::steady_clock;

/// [x, y, z, w nx, w ny, w nz]: the 6-D space of eq. KD6.
class SixDRepresentation : public pcl::PointRepresentation<pcl::PointNormal> {
 public:
  explicit SixDRepresentation(float w) : w_(w) { nr_dimensions_ = 6; }
  void copyToFloatArray(const pcl::PointNormal& p, float* out) const override {
    out[0] = p.x, out[1] = p.y, out[2] = p.z;
    out[3] = w_ * p.normal_x, out[4] = w_ * p.normal_y, out[5] = w_ * p.normal_z;
  }

 private:
  float w_;
};

struct Association {
  Eigen::Vector3d q, m;      ///< R_ref p_m and R_ref n_m (camera orientation, before t)
  Eigen::Vector3d p_l, n_l;  ///< face centroid and normal in the LiDAR frame
  Eigen::Vector3d p_s, n_s;  ///< stereo point and normal (camera frame)
  double inv_sigma = 1.0;
  int cluster = 0;  ///< keyframe and image cell, for the cluster-robust covariance
  double d = 1.0;   ///< the stereo point's disparity (px)
  double g = 0.0;   ///< its disparity change per rad of right-camera yaw, f (1 + x_r^2)
};

/// The associations of every keyframe of a window of `n`: `fill(k, &list)` collects keyframe k's,
/// on `threads` threads, and the lists are joined in window order (the same set on any number of
/// threads).
template <typename Fill>
std::vector<Association> associateKeyframes(size_t n, int threads, Fill&& fill) {
  std::vector<std::vector<Association>> per_kf(n);
  parallelFor(static_cast<int>(n), threads, [&](int k) { fill(k, &per_kf[k]); });
  size_t total = 0;
  for (const auto& p : per_kf) total += p.size();
  std::vector<Association> all;
  all.reserve(total);
  for (const auto& p : per_kf) all.insert(all.end(), p.begin(), p.end());
  return all;
}

/// Disparity change of a rectified stereo point per rad of right-camera yaw (see
/// correctedStereoScale): f (1 + x_r^2), x_r the normalised right image coordinate.
double yawGain(const StereoCloud& st, double u, double d) {
  const double xr = (u - d - st.cx) / st.fx;
  return st.fx * (1.0 + xr * xr);
}

/// The stereo point of `a` as the current scale and yaw place it.
Eigen::Vector3d correctedPoint(const Association& a, double scale, double yaw) {
  return correctedStereoScale(&scale, &yaw, a.d, a.g) * a.p_s;
}

/// Solves the 6-DoF update of one association set; returns [phi; tau].
Vector6d solveUpdate(const std::vector<Association>& as, const Eigen::Vector3d& t_ref, bool coarse,
                     const LidarStereoSettings& s, double loss_scale, double* scale, double* yaw) {
  double delta[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  std::unique_ptr<ceres::LossFunction> loss;
  if (coarse)
    loss = std::make_unique<ceres::CauchyLoss>(loss_scale);
  else
    loss = std::make_unique<ceres::HuberLoss>(loss_scale);
  for (const auto& a : as) {
    if (coarse) {
      problem.AddResidualBlock(
          PointPlaneNormalResidual::Create(a.q, a.m, t_ref, a.p_s, a.n_s, a.inv_sigma,
                                           s.normal_residual_weight, a.d, a.g),
          loss.get(), delta, scale, yaw);
    } else {
      problem.AddResidualBlock(
          LidarNormalResidual::Create(a.q, a.m, t_ref, a.p_s, a.inv_sigma, a.d, a.g), loss.get(),
          delta, scale, yaw);
    }
  }
  if (!as.empty()) {
    const bool nuisances = !coarse || s.coarse_estimates_stereo_nuisances;
    if (s.estimate_stereo_scale && nuisances) {
      problem.SetParameterLowerBound(scale, 0, 1.0 / s.max_stereo_scale);
      problem.SetParameterUpperBound(scale, 0, s.max_stereo_scale);
    } else {
      problem.SetParameterBlockConstant(scale);
    }
    if (s.estimate_stereo_yaw && nuisances) {
      const double limit = s.max_stereo_yaw_deg / kDegPerRad;
      problem.SetParameterLowerBound(yaw, 0, -limit);
      problem.SetParameterUpperBound(yaw, 0, limit);
    } else {
      problem.SetParameterBlockConstant(yaw);
    }
  }
  ceres::Solver::Options opt;
  opt.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  opt.max_num_iterations = s.ceres_iterations;
  opt.num_threads = s.threads;
  opt.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  const double scale_before = *scale, yaw_before = *yaw;
  ceres::Solve(opt, &problem, &summary);
  if (std::getenv("TESCALIB_DEBUG")) std::fprintf(stderr, "%s\n", summary.BriefReport().c_str());
  Vector6d d;
  // A failed solve (an infeasible bound, NaN residuals) leaves delta at 0, which the stages
  // would take for "settled" at the start (review, session 34): NaN tells them it failed.
  if (!summary.IsSolutionUsable()) {
    *scale = scale_before, *yaw = yaw_before;
    return Vector6d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  for (int i = 0; i < 6; ++i) d[i] = delta[i];
  return d;
}

/// The statistical part plus the common biases through `h` (LidarStereoResult::bias_sensitivity
/// or bias_sensitivity_held).
Matrix6d withCommonBiases(const LidarStereoResult& r, const LidarStereoSettings& s,
                          const Eigen::Matrix<double, 6, 2>& h) {
  return r.covariance_statistical +
         std::pow(disparityBiasSigma(r, s), 2) * h.col(0) * h.col(0).transpose() +
         std::pow(s.model_sigma_range_m, 2) * h.col(1) * h.col(1).transpose();
}

/// The covariance of what the window constrains (the trust flags): the statistical part plus
/// the common biases, with the clouds' scale and yaw held (they absorb only a uniform offset).
Matrix6d constrainedCovariance(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return withCommonBiases(r, s, r.bias_sensitivity_held);
}

bool smallUpdate(const Vector6d& d, const LidarStereoSettings& s) {
  return d.head<3>().norm() * kDegPerRad < s.converge_rot_deg &&
         d.tail<3>().norm() < s.converge_trans_m;
}

}  // namespace

bool disparityOffsetMeasured(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return r.disparity_offset_sigma_px > 0 &&
         r.disparity_offset_sigma_px <= s.max_disparity_offset_sigma_px &&
         std::fabs(r.disparity_offset_px) >
             s.disparity_offset_significance * r.disparity_offset_sigma_px;
}

double disparityBiasSigma(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return disparityOffsetMeasured(r, s)
             ? std::max(s.model_sigma_disparity_px, std::fabs(r.disparity_offset_px))
             : s.model_sigma_disparity_px;
}

bool disparityOffsetWidensBias(const LidarStereoResult& r, const LidarStereoSettings& s) {
  return disparityBiasSigma(r, s) > s.model_sigma_disparity_px;
}

bool trustFlags(const Matrix6d& covariance, const LidarStereoSettings& s, bool observable[6]) {
  return axesWithin(covariance, s.max_sigma_rot_deg, s.max_sigma_trans_m, observable);
}

// Variance of a LiDAR point along unit normal n (camera frame), eq. lidar_noise projected:
// range noise along the beam, beam-direction noise (times the range) across it.
double lidarVarianceAlong(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const LidarStereoSettings& s) {
  const double c = n.dot(beam_dir);
  const double lateral = range * s.lidar_beam_sigma_deg * M_PI / 180.0;
  return s.lidar_range_sigma * s.lidar_range_sigma * c * c + lateral * lateral * (1.0 - c * c);
}

double pointPlaneInvSigma(const Eigen::Vector3d& n, const Eigen::Vector3d& beam_dir, double range,
                          const Eigen::Vector3d& stereo_point, double disparity,
                          double stereo_scale, double disparity_sigma,
                          const LidarStereoSettings& s) {
  const double dFdd = stereo_scale * std::fabs(n.dot(stereo_point)) / disparity;
  const double var =
      lidarVarianceAlong(n, beam_dir, range, s) + dFdd * dFdd * disparity_sigma * disparity_sigma;
  return 1.0 / std::sqrt(var);
}

LidarStereoResult solveLidarStereo(const std::vector<const Keyframe*>& window,
                                   const Eigen::Isometry3d& T_init, const LidarStereoSettings& s) {
  LidarStereoResult res;
  res.T_cam_lidar = T_init;
  res.T_after_coarse = T_init;
  if (window.empty()) {
    res.message = "empty window";
    return res;
  }
  if (!isRigidTransform(T_init)) {
    res.message = "the initial T_cam_lidar is not a rigid transform (NaN, or not a rotation)";
    return res;
  }
  if (s.cov_cells_x < 1 || s.cov_cells_y < 1 || s.ceres_iterations < 1 || s.threads < 1) {
    res.message = "cov_cells_x, cov_cells_y, ceres_iterations and threads must be at least 1";
    return res;
  }
  // Non-finite or non-positive limits pass every gate (NaN compares false); bounds of zero width
  // make Ceres fail (review, session 34).
  for (const double v : {s.normal_weight, s.coarse_loss_scale, s.fine_huber, s.fine_gate_sigma,
                         s.max_depth, s.lidar_range_sigma, s.disparity_sigma})
    if (!(v > 0) || !std::isfinite(v)) {
      res.message =
          "normal_weight, coarse_loss_scale, fine_huber, fine_gate_sigma, max_depth, "
          "lidar_range_sigma and disparity_sigma must be positive numbers";
      return res;
    }
  if ((s.estimate_stereo_scale &&
       (!(s.max_stereo_scale > 1) || !std::isfinite(s.max_stereo_scale) ||
        !(s.initial_stereo_scale > 0) || !std::isfinite(s.initial_stereo_scale))) ||
      (s.estimate_stereo_yaw &&
       (!(s.max_stereo_yaw_deg > 0) || !std::isfinite(s.max_stereo_yaw_deg) ||
        !std::isfinite(s.initial_stereo_yaw_rad)))) {
    res.message =
        "the clouds' scale and yaw need max_stereo_scale > 1, max_stereo_yaw_deg > 0 and finite "
        "starts";
    return res;
  }
  Eigen::Isometry3d T = T_init;
  double scale = s.estimate_stereo_scale ? std::clamp(s.initial_stereo_scale,
                                                      1.0 / s.max_stereo_scale, s.max_stereo_scale)
                                         : 1.0;
  double yaw = s.estimate_stereo_yaw ? s.initial_stereo_yaw_rad : 0.0;

  // ---------------------------------------------------------------- coarse (eq. KD6 + eq. 2)
  const auto t_coarse = Clock::now();
  bool solver_failed = false;  // a Ceres update was not usable: not converged, said so
  if (s.run_coarse) {
    std::vector<pcl::KdTreeFLANN<pcl::PointNormal>> trees(window.size());
    std::vector<std::vector<size_t>> tree_index(window.size());
    std::vector<std::vector<size_t>> face_index(window.size());
    auto repr = std::make_shared<SixDRepresentation>(static_cast<float>(s.normal_weight));
    const int coarse_faces =
        std::min(s.coarse_faces_per_keyframe,
                 s.coarse_faces_per_window / std::max(1, static_cast<int>(window.size())));
    for (size_t k = 0; k < window.size(); ++k) {
      const auto& pts = window[k]->stereo.points;
      tree_index[k] = evenlyStrided(pts.size(), s.coarse_stereo_points_per_keyframe);
      face_index[k] = sampleFaces(window[k]->mesh, coarse_faces);
      if (tree_index[k].empty()) continue;
      pcl::PointCloud<pcl::PointNormal>::Ptr cloud(new pcl::PointCloud<pcl::PointNormal>);
      for (size_t i : tree_index[k]) {
        pcl::PointNormal p;
        p.x = pts[i].p.x(), p.y = pts[i].p.y(), p.z = pts[i].p.z();
        p.normal_x = pts[i].n.x(), p.normal_y = pts[i].n.y(), p.normal_z = pts[i].n.z();
        cloud->push_back(p);
      }
      trees[k].setPointRepresentation(repr);
      trees[k].setInputCloud(cloud);
    }
    for (double gate : s.coarse_gates) {
      if (solver_failed) break;  // the result is not converged: no later gate, no fine stage
      for (int it = 0; it < s.coarse_reassociations; ++it) {
        if (s.cancelled()) {
          res.message = "cancelled";
          return res;
        }
        ++res.iterations;
        const Eigen::Matrix3d R = T.linear();
        auto associate = [&](int k, std::vector<Association>* kf_as) {
          if (tree_index[k].empty()) return;
          std::vector<int> nn(1);
          std::vector<float> nn_d2(1);
          const auto& pts = window[k]->stereo.points;
          for (size_t fi : face_index[k]) {
            const MeshFace& f = window[k]->mesh.faces[fi];
            const Eigen::Vector3d q = R * f.centroid.cast<double>();
            const Eigen::Vector3d c = q + T.translation();
            const Eigen::Vector3d m = R * f.normal.cast<double>();
            // Only faces the stereo camera can have measured: in the image and in its depth range
            // (a far facade beyond the stereo range would otherwise pull the estimate forward).
            const StereoCloud& st = window[k]->stereo;
            const Eigen::Vector3d pr = st.R_rect_left * c;
            if (pr.z() < 1.0 || pr.z() > s.max_depth) continue;
            const double u = st.fx * pr.x() / pr.z() + st.cx, v = st.fy * pr.y() / pr.z() + st.cy;
            if (u < 0 || v < 0 || u >= st.disparity.cols || v >= st.disparity.rows) continue;
            pcl::PointNormal query;
            query.x = float(c.x() / scale), query.y = float(c.y() / scale),
            query.z = float(c.z() / scale);
            query.normal_x = float(m.x()), query.normal_y = float(m.y()),
            query.normal_z = float(m.z());
            if (trees[k].nearestKSearch(query, 1, nn, nn_d2) < 1 || nn_d2[0] > gate * gate)
              continue;
            const StereoPoint& sp = pts[tree_index[k][nn[0]]];
            Association a;
            a.q = q, a.m = m;
            a.p_l = f.centroid.cast<double>(), a.n_l = f.normal.cast<double>();
            a.p_s = sp.p.cast<double>(), a.n_s = sp.n.cast<double>();
            a.d = sp.disparity;
            const Eigen::Vector3d sr = st.R_rect_left * a.p_s;
            a.g = yawGain(st, st.fx * sr.x() / sr.z() + st.cx, a.d);
            // Point-to-plane noise: LiDAR along the normal plus stereo depth noise along it.
            const Eigen::Vector3d beam = c.normalized();
            a.inv_sigma = pointPlaneInvSigma(m, beam, f.range, a.p_s, sp.disparity, 1.0,
                                             s.disparity_sigma, s);
            kf_as->push_back(a);
          }
        };
        const std::vector<Association> as = associateKeyframes(window.size(), s.threads, associate);
        res.coarse_inliers = static_cast<int>(as.size());
        if (static_cast<int>(as.size()) < s.min_inliers) break;
        const Vector6d d =
            solveUpdate(as, T.translation(), true, s, s.coarse_loss_scale, &scale, &yaw);
        if (!d.allFinite()) {
          solver_failed = true;
          break;
        }
        T = perturb(T, d);
        if (smallUpdate(d, s)) break;
      }
    }
  }
  res.T_after_coarse = T;
  res.seconds_coarse = secondsSince(t_coarse);

  // ---------------------------------------------------------------- fine (eq. 3, projective)
  const auto t_fine = Clock::now();
  bool settled = !s.run_fine;
  std::vector<Association> as;
  if (s.run_fine && !solver_failed) {
    std::vector<std::vector<size_t>> face_index(window.size());
    for (size_t k = 0; k < window.size(); ++k)
      face_index[k] = sampleFaces(window[k]->mesh, s.fine_faces_per_keyframe);
    Vector6d d_prev = Vector6d::Zero();
    for (int it = 0; it < s.fine_reassociations; ++it) {
      if (s.cancelled()) {
        res.message = "cancelled";
        return res;
      }
      ++res.iterations;
      const Eigen::Matrix3d R = T.linear();
      auto associate = [&](int kf, std::vector<Association>* kf_as) {
        const StereoCloud& st = window[kf]->stereo;
        for (size_t fi : face_index[kf]) {
          const MeshFace& f = window[kf]->mesh.faces[fi];
          const Eigen::Vector3d q = R * f.centroid.cast<double>();
          const Eigen::Vector3d c = q + T.translation();
          const Eigen::Vector3d pr = st.R_rect_left * c;
          if (pr.z() < 1.0 || pr.z() > s.max_depth) continue;
          const double u = st.fx * pr.x() / pr.z() + st.cx, v = st.fy * pr.y() / pr.z() + st.cy;
          double d;
          if (!st.disparityAt(u, v, &d)) continue;
          const Eigen::Vector3d ps = st.pointAt(u, v, d);  // unscaled; the residual scales it
          const Eigen::Vector3d m = R * f.normal.cast<double>();
          const double g = yawGain(st, u, d);
          const double k = correctedStereoScale(&scale, &yaw, d, g);
          // The point sits at the yaw-corrected disparity (the clamp of correctedStereoScale):
          // its depth noise is that disparity's (session 32 review: the raw one weighted far
          // points up to 2.6x wrong with the clouds 0.3 deg off in yaw).
          const double inv_sigma =
              pointPlaneInvSigma(m, c.normalized(), f.range, ps, std::max(d + g * yaw, 0.1 * d), k,
                                 s.disparity_sigma, s);
          if (std::fabs(m.dot(c - k * ps)) * inv_sigma > s.fine_gate_sigma) continue;
          const int cell =
              std::clamp(static_cast<int>(u * s.cov_cells_x / st.disparity.cols), 0,
                         s.cov_cells_x - 1) +
              s.cov_cells_x * std::clamp(static_cast<int>(v * s.cov_cells_y / st.disparity.rows), 0,
                                         s.cov_cells_y - 1);
          kf_as->push_back({q, m, f.centroid.cast<double>(), f.normal.cast<double>(), ps,
                            Eigen::Vector3d::Zero(), inv_sigma,
                            static_cast<int>(kf) * s.cov_cells_x * s.cov_cells_y + cell, d, g});
        }
      };
      as = associateKeyframes(window.size(), s.threads, associate);
      res.fine_inliers = static_cast<int>(as.size());
      if (static_cast<int>(as.size()) < s.min_inliers) break;
      const Vector6d d = solveUpdate(as, T.translation(), false, s, s.fine_huber, &scale, &yaw);
      if (!d.allFinite()) {
        solver_failed = true;
        break;
      }
      if (std::getenv("TESCALIB_DEBUG"))
        std::fprintf(stderr,
                     "fine it %d: %zu assoc, update %.5f deg %.5f m (rot [%.5f %.5f %.5f] deg, "
                     "t [%.5f %.5f %.5f] m), scale %.5f, yaw %.5f deg\n",
                     it, as.size(), d.head<3>().norm() * kDegPerRad, d.tail<3>().norm(),
                     d[0] * kDegPerRad, d[1] * kDegPerRad, d[2] * kDegPerRad, d[3], d[4], d[5],
                     scale, yaw * kDegPerRad);
      T = perturb(T, d);
      // Projective re-association makes the last updates wiggle at the 0.1 mm level: settled
      // means well below the noise, not exactly still. It can also alternate between two
      // association sets (a 2-cycle, seen with the stereo scale and yaw free): then the net
      // move over the last two updates is what must be small, and the midpoint is kept.
      auto below = [&](const Vector6d& x) {
        return x.head<3>().norm() * kDegPerRad < s.fine_settle_rot_deg &&
               x.tail<3>().norm() < s.fine_settle_trans_m;
      };
      if (below(d)) {
        settled = true;
        break;
      }
      if (it > 0 && below(d + d_prev) && below(0.2 * d)) {
        T = perturb(T, -0.5 * d);
        settled = true;
        break;
      }
      d_prev = d;
    }
  }
  res.seconds_fine = secondsSince(t_fine);
  res.T_cam_lidar = T;
  res.stereo_scale = scale;
  res.stereo_yaw_rad = yaw;
  res.settled = settled && !solver_failed;
  if (solver_failed) {
    res.message = "Ceres could not solve an update (NaN residuals, or an infeasible bound)";
    return res;
  }

  // ---------------------------------------------------------------- information, honesty
  // Analytic Jacobian of r = (R m)^T (R q + t - s) / sigma at the estimate:
  //   dr/dphi = (m x (t - s))^T / sigma,  dr/dtau = m^T / sigma  (m, q already rotated).
  // H = sum w J^T J is the information of eq. residual_uncertainty: the residuals are already
  // divided by their noise-model sigma (J_w Sigma J_w^T of the paper), so H^-1 is the paper's
  // covariance. It assumes independent residuals; neighbouring residuals share SGBM and
  // association errors, so it is over-confident. The published covariance is the
  // cluster-robust sandwich H^-1 (sum_c g_c g_c^T) H^-1 with g_c = sum_{i in c} w_i J_i^T r_i
  // over clusters c = (keyframe, image cell): errors shared inside a cell count once (never below
  // the paper's covariance scaled by the residuals' robust variance). Neither sees errors common
  // to the whole window (association and matching biases), so a calibrated model-error
  // covariance is added.
  // With the stereo scale and yaw free, the pose shares information with them: the covariance
  // is the pose block of the full inverse (the nuisance parameters marginalised), otherwise a
  // window that cannot separate the LiDAR's forward offset from the clouds' scale or yaw would
  // look well constrained.
  const int n_scale = s.estimate_stereo_scale ? 1 : 0;
  const int n = 6 + n_scale + (s.estimate_stereo_yaw ? 1 : 0);
  std::vector<double> abs_res;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  std::vector<Eigen::VectorXd> scores;
  // sum w J dr/db for the window-common biases: disparity offset (px), LiDAR range offset (m).
  Eigen::MatrixXd JtD = Eigen::MatrixXd::Zero(n, 2);
  double DtD = 0;                     // sum w D^2, D = dr / d(disparity offset)
  std::vector<double> offset_scores;  // per cluster sum w r D (with `scores`: the offset's share)
  double cost = 0;
  if (!as.empty()) {
    int n_clusters = 0;
    for (const auto& a0 : as) n_clusters = std::max(n_clusters, a0.cluster + 1);
    scores.assign(n_clusters, Eigen::VectorXd::Zero(n));
    offset_scores.assign(n_clusters, 0.0);
    res.keyframe_information.assign(window.size(), Matrix6d::Zero());
    Eigen::VectorXd J(n);
    for (const auto& a0 : as) {
      const Eigen::Vector3d m = T.linear() * a0.n_l, q = T.linear() * a0.p_l;
      const Eigen::Vector3d ps = correctedPoint(a0, scale, yaw);
      const double r = m.dot(q + T.translation() - ps) * a0.inv_sigma;
      J.head<3>() = m.cross(T.translation() - ps) * a0.inv_sigma;
      J.segment<3>(3) = m * a0.inv_sigma;
      // ps = scale d / (d + g yaw) p_s
      const double dc = a0.d + a0.g * yaw, mp = m.dot(a0.p_s) * a0.inv_sigma;
      if (n_scale) J[6] = -mp * a0.d / dc;
      if (s.estimate_stereo_yaw) J[6 + n_scale] = mp * scale * a0.d * a0.g / (dc * dc);
      const double w = std::fabs(r) <= s.fine_huber ? 1.0 : s.fine_huber / std::fabs(r);
      H += w * J * J.transpose();
      // ps ~ d / (d + delta): dr/d(delta) = m.ps / d_c; q = R p_l: dr/d(range) = m.R p_l / |p_l|.
      const double D = m.dot(ps) / dc * a0.inv_sigma;
      JtD.col(0) += w * J * D;
      DtD += w * D * D;
      offset_scores[a0.cluster] += w * r * D;
      JtD.col(1) += w * J * (m.dot(q) / a0.p_l.norm() * a0.inv_sigma);
      res.keyframe_information[a0.cluster / (s.cov_cells_x * s.cov_cells_y)] +=
          w * J.head<6>() * J.head<6>().transpose();
      scores[a0.cluster] += w * r * J;
      cost += w * r * r;
      abs_res.push_back(std::fabs(r));
    }
    cost /= as.size();
    std::nth_element(abs_res.begin(), abs_res.begin() + abs_res.size() / 2, abs_res.end());
    res.residual_scale = 1.4826 * abs_res[abs_res.size() / 2];
  }
  res.final_cost = cost;
  bool all_observable = false;
  if (!as.empty()) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
    if (eig.eigenvalues().minCoeff() > 1e-12 * std::max(1.0, eig.eigenvalues().maxCoeff())) {
      const Eigen::MatrixXd H_inv_full = H.inverse();
      const Matrix6d H_inv = H_inv_full.topLeftCorner<6, 6>();
      res.information = H_inv.inverse();  // the pose's marginal information
      res.covariance_known = true;
      res.covariance_model = H_inv;
      const Eigen::MatrixXd bias_moves = -(H_inv_full * JtD);  // pose, scale, yaw per bias
      res.bias_sensitivity = bias_moves.topRows<6>();
      if (n == 6)
        res.bias_sensitivity_held = res.bias_sensitivity;
      else
        res.bias_sensitivity_held = -(H.topLeftCorner<6, 6>().ldlt().solve(JtD.topRows<6>()));
      // The window-common disparity offset these residuals show: one Gauss-Newton step of the
      // problem with the offset added as a parameter, from this estimate (offset 0), the pose
      // (and scale) re-solved with it, and its cluster-robust sigma (the same sandwich as the
      // pose's). With the clouds' yaw estimated the offset is a parameter already.
      if (s.measure_disparity_offset && !s.estimate_stereo_yaw) {
        Eigen::MatrixXd Ha(n + 1, n + 1);
        Ha << H, JtD.col(0), JtD.col(0).transpose(), DtD;
        Eigen::VectorXd ga = Eigen::VectorXd::Zero(n + 1);
        Eigen::MatrixXd Ma = Eigen::MatrixXd::Zero(n + 1, n + 1);
        Eigen::VectorXd gc(n + 1);
        int used_a = 0;
        for (size_t c = 0; c < scores.size(); ++c) {
          gc << scores[c], offset_scores[c];
          if (gc.squaredNorm() == 0) continue;
          ga += gc;
          Ma += gc * gc.transpose();
          ++used_a;
        }
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_a(Ha);
        if (used_a > 1 && eig_a.eigenvalues().minCoeff() >
                              1e-12 * std::max(1.0, eig_a.eigenvalues().maxCoeff())) {
          Ma *= double(used_a) / double(used_a - 1);
          const Eigen::MatrixXd Ha_inv = Ha.inverse();
          res.disparity_offset_px = -(Ha_inv * ga)(n);
          const double k2a = res.residual_scale * res.residual_scale;
          res.disparity_offset_sigma_px =
              std::sqrt(std::max((Ha_inv * Ma * Ha_inv)(n, n), k2a * Ha_inv(n, n)));
          if (std::getenv("TESCALIB_DEBUG"))
            std::fprintf(stderr, "disparity offset %+.4f px, sigma %.4f px\n",
                         res.disparity_offset_px, res.disparity_offset_sigma_px);
        }
      }
      Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
      int used = 0;
      for (const Eigen::VectorXd& g : scores)
        if (g.squaredNorm() > 0) M += g * g.transpose(), ++used;
      if (used > 1) M *= double(used) / double(used - 1);  // small-sample correction
      const Eigen::MatrixXd sandwich = H_inv_full * M * H_inv_full;
      res.covariance = sandwich.topLeftCorner<6, 6>();
      res.covariance = 0.5 * (res.covariance + res.covariance.transpose()).eval();
      if (n_scale) res.stereo_scale_variance = sandwich(6, 6);
      // Never below the paper's model scaled by the residuals' own spread.
      const double k2 = res.residual_scale * res.residual_scale;
      const Matrix6d floor = k2 * H_inv;
      for (int i = 0; i < 6; ++i)
        if (!(res.covariance(i, i) >= floor(i, i))) {
          res.covariance = floor;
          if (n_scale) res.stereo_scale_variance = k2 * H_inv_full(6, 6);
          break;
        }
      if (n_scale) {  // the common biases move the scale too
        res.stereo_scale_variance += std::pow(disparityBiasSigma(res, s) * bias_moves(6, 0), 2) +
                                     std::pow(s.model_sigma_range_m * bias_moves(6, 1), 2);
      }
      res.covariance_statistical = res.covariance;
      // Model error that more data does not average away (calibrated on generated drives, see
      // the README): common biases through this window's sensitivity to them, and a floor per axis.
      // What the window constrains is the statistical part and the common biases (a weakly
      // constrained axis is the one they move furthest: the highway's optical axis), without
      // the scene-independent floor.
      const Matrix6d constrained = constrainedCovariance(res, s);
      all_observable = trustFlags(constrained, s, res.observable);
      res.weak_directions = weakDirections(constrained, s.max_sigma_rot_deg, s.max_sigma_trans_m);
      res.covariance = withCommonBiases(res, s, res.bias_sensitivity);
      addAxisVariances(&res.covariance, s.model_sigma_rot_deg, s.model_sigma_trans_m);
    } else {
      res.information = H.topLeftCorner<6, 6>();
      res.covariance = res.covariance_model = res.covariance_statistical =
          Matrix6d::Identity() * 1e6;
    }
  }
  const Vector6d correction = poseError(T, T_init);
  const bool diverged = correction.head<3>().norm() * kDegPerRad > s.max_correction_rot_deg ||
                        correction.tail<3>().norm() > s.max_correction_trans_m;
  res.converged = false;
  if (res.fine_inliers < s.min_inliers && s.run_fine)
    res.message = "too few LiDAR-stereo associations (" + std::to_string(res.fine_inliers) + ")";
  else if (diverged)
    res.message = "diverged: the correction from the initial guess is implausibly large";
  else if (s.estimate_stereo_scale &&
           std::fabs(std::log(res.stereo_scale)) >= std::log(s.max_stereo_scale) - 1e-4) {
    // A minimum on the bound is the bound's, not the data's (session 28: a co start 10 deg / 1 m
    // off converged there, the LiDAR 1.1 m off, and ran away in later rounds).
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the stereo scale ended on its bound (%.3f): the clouds' depth and the LiDAR's "
                  "disagree by more than a baseline error can explain",
                  res.stereo_scale);
    res.message = buf;
  } else if (s.estimate_stereo_yaw &&
             std::fabs(res.stereo_yaw_rad) * kDegPerRad >= s.max_stereo_yaw_deg - 1e-6) {
    // The same for the yaw: a pinned nuisance is not marginalised, its covariance not the
    // pose's (review, session 34: yaw on a 0.1 deg bound, tz 3.2 cm off at sigma 0.48 cm).
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the clouds' yaw ended on its bound (%.3f deg): the right camera is turned "
                  "further than max_stereo_yaw_deg allows",
                  res.stereo_yaw_rad * kDegPerRad);
    res.message = buf;
  } else if (!all_observable && disparityOffsetWidensBias(res, s)) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the window does not constrain every axis with the common disparity offset its "
                  "residuals show (%+.2f px, model %.2f px: rectification or matching bias?)",
                  res.disparity_offset_px, s.model_sigma_disparity_px);
    res.message = buf + weakestClause(res.weak_directions);
  } else if (!all_observable)
    res.message = "the window does not constrain every axis (degenerate scene)" +
                  weakestClause(res.weak_directions);
  else if (!settled)
    res.message = "the fine stage did not settle within its iteration budget";
  else
    res.converged = true;
  if (res.converged && s.check_window_halves) checkWindowHalves(window, s, &res);
  // Cancelled at any point (a stage, or the halves): not converged, whatever it reached (the
  // header's promise; review, session 34: a cancel during the halves left a "tested" check).
  if (s.cancelled()) {
    res.converged = false;
    res.message = "cancelled";
  }
  return res;
}

LidarStereoResult solveLidarStereoSearch(const std::vector<const Keyframe*>& window,
                                         const Eigen::Isometry3d& T_init,
                                         const LidarStereoSettings& s) {
  LidarStereoResult first = solveLidarStereo(window, T_init, s);
  if (first.converged || !(s.search_step_deg > 0) || !std::isfinite(s.search_step_deg) ||
      window.empty() || !isRigidTransform(T_init))
    return first;
  const double step = s.search_step_deg / kDegPerRad;
  const double offsets[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  std::optional<LidarStereoResult> best;
  for (const auto& o : offsets) {
    if (s.cancelled()) break;
    Vector6d d = Vector6d::Zero();
    d(0) = o[0] * step, d(1) = o[1] * step;
    LidarStereoResult r = solveLidarStereo(window, perturb(T_init, d), s);
    r.search_offset_rad = d.head<3>();
    if (r.converged && (!best || r.fine_inliers > best->fine_inliers)) best = std::move(r);
  }
  if (s.cancelled()) {
    first.message = "cancelled";
    return first;
  }
  if (best) {
    best->search_starts = 9;
    return *best;
  }
  first.search_starts = 9;
  first.message += " (and from none of 8 starts turned by +-" +
                   std::to_string(static_cast<int>(std::lround(s.search_step_deg))) +
                   " deg about the camera's x and y axes)";
  return first;
}

void checkWindowHalves(const std::vector<const Keyframe*>& window, const LidarStereoSettings& s,
                       LidarStereoResult* full) {
  const auto t0 = Clock::now();
  full->halves = LidarStereoResult::Halves();
  const size_t half = window.size() / 2;
  if (s.min_keyframes_per_half < 1 || half < static_cast<size_t>(s.min_keyframes_per_half)) return;
  LidarStereoSettings hs = s;
  hs.run_coarse = false;
  hs.check_window_halves = false;
  hs.initial_stereo_yaw_rad = full->stereo_yaw_rad;
  hs.initial_stereo_scale = full->stereo_scale;
  // A half constrains less than the window: its fine stage may need longer to settle.
  hs.fine_reassociations = 2 * s.fine_reassociations;
  const std::vector<const Keyframe*> first(window.begin(), window.begin() + half),
      second(window.begin() + half, window.end());
  // The two halves are independent solves: side by side.
  LidarStereoResult halves[2];
  parallelFor(2, s.threads, [&](int h) {
    halves[h] = solveLidarStereo(h == 0 ? first : second, full->T_cam_lidar, hs);
  });
  const LidarStereoResult& a = halves[0];
  const LidarStereoResult& b = halves[1];
  full->halves.seconds = secondsSince(t0);
  // Only halves with a covariance are compared (a cancelled or failed half returns its start and
  // a placeholder, which would pass as agreement).
  for (const LidarStereoResult* r : {&a, &b})
    if (r->fine_inliers < s.min_inliers || !r->covariance_known || s.cancelled()) return;
  const Vector6d e = poseError(a.T_cam_lidar, b.T_cam_lidar);
  const Matrix6d S = a.covariance + b.covariance;
  const double chi2 = e.dot(S.ldlt().solve(e));
  if (!std::isfinite(chi2)) return;
  if (std::getenv("TESCALIB_DEBUG")) {
    std::fprintf(stderr,
                 "window halves: chi2 %.1f, difference rot [%.4f %.4f %.4f] deg, "
                 "t [%.2f %.2f %.2f] cm\n",
                 chi2, e[0] * kDegPerRad, e[1] * kDegPerRad, e[2] * kDegPerRad, e[3] * 100,
                 e[4] * 100, e[5] * 100);
    for (const LidarStereoResult* h : {&a, &b}) {
      const Vector6d sd = h->covariance.diagonal().cwiseSqrt();
      std::fprintf(stderr,
                   "  half: settled %d, %d iterations, sigma rot [%.4f %.4f %.4f] deg, "
                   "t [%.2f %.2f %.2f] cm\n",
                   h->settled, h->iterations, sd[0] * kDegPerRad, sd[1] * kDegPerRad,
                   sd[2] * kDegPerRad, sd[3] * 100, sd[4] * 100, sd[5] * 100);
    }
  }
  full->halves.tested = true;
  full->halves.chi2 = chi2;
  full->halves.difference = e;
  if (chi2 <= s.halves_chi2_limit) return;
  // The halves disagree beyond what the covariances allow: the data hold an error the model
  // does not know (on real KITTI, sequences of one day differ by 3-6 sigma). Scale the
  // covariances by the observed disagreement (chi2 / DoF) and judge the axes again.
  const double k = chi2 / 6.0;
  full->halves.covariance_scale = k;
  const Matrix6d constrained = k * constrainedCovariance(*full, s);
  full->covariance *= k;
  full->covariance_statistical *= k;
  full->stereo_scale_variance *= k;
  full->weak_directions = weakDirections(constrained, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  if (!trustFlags(constrained, s, full->observable) && full->converged) {
    full->converged = false;
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the window's two halves disagree (chi2 %.1f > %.1f, 6 DoF): covariance scaled "
                  "by %.1f, and then the window does not constrain every axis",
                  chi2, s.halves_chi2_limit, k);
    full->message = buf + weakestClause(full->weak_directions);
  }
}

}  // namespace tescalib
