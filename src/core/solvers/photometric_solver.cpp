#include "tescalib/core/solvers/photometric_solver.h"

#include <array>
#include <chrono>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/solvers/residuals/photometric_residual.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// Weight of the stiff baseline-length prior: residual units per metre (1 per 0.1 mm).
constexpr double kBaselineLengthWeight = 1e4;

/// Stiff prior |t_ref + tau| = length (units: 0.1 mm).
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

/// One pyramid level of one keyframe: images as doubles for Ceres' interpolator.
struct Level {
  cv::Mat left, right;  ///< CV_64F
  std::vector<double> right_data;
  std::unique_ptr<ceres::Grid2D<double, 1>> grid;
  std::unique_ptr<ImageInterpolator> interp;
  CameraIntrinsics left_cam, right_cam;
};

/// A used key point's residual and the row D with d(log depth) = D d[phi; tau] of T_cam_lidar.
struct DepthLink {
  PhotometricResidual residual;
  int keyframe;
  Eigen::Matrix<double, 1, 6> D;
};

/// How the depth of the point X (left camera frame) on face `f` follows a perturbation
/// [phi; tau] of T_cam_lidar (R = Exp(phi) R, t = t + tau): the face moves by
/// phi x (X - t) + tau, along its normal n by n.(...), and the ray's depth by that over n.X
/// (relative: d log Z = (phi.((X - t) x n) + tau.n) / n.X).
Eigen::Matrix<double, 1, 6> depthRow(const MeshFace& f, const Eigen::Isometry3d& T_cam_lidar,
                                     const Eigen::Vector3d& X) {
  const Eigen::Vector3d n =
      T_cam_lidar.linear() * (f.b - f.a).cross(f.c - f.a).cast<double>().normalized();
  const double nx = n.dot(X);
  Eigen::Matrix<double, 1, 6> D = Eigen::Matrix<double, 1, 6>::Zero();
  if (std::fabs(nx) < 1e-9) return D;
  D.head<3>() = (X - T_cam_lidar.translation()).cross(n).transpose() / nx;
  D.tail<3>() = n.transpose() / nx;
  return D;
}

/// First-order sensitivity of the solution to the LiDAR extrinsic (implicit function theorem on
/// the Gauss-Newton normal equations with the Huber weights at the solution):
///   d x / d xi = -H^-1 sum_i w_i J_x,i^T J_rho,i D_i,   H = sum_i w_i J_x,i^T J_x,i (+ prior),
/// x = [delta; per-keyframe (a, b)], rho = a key point's log depth; the pose rows are returned.
Matrix6d lidarSensitivity(const std::vector<DepthLink>& links, const double* delta,
                          const std::vector<std::array<double, 2>>& ab, double huber,
                          const Eigen::Isometry3d* fixed_length_at) {
  const int n = 6 + 2 * static_cast<int>(ab.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n), B = Eigen::MatrixXd::Zero(n, 6);
  double r[kPatternSize], jd[kPatternSize * 6], jab[kPatternSize * 2], jr[kPatternSize];
  const double rho0 = 0.0;
  for (const DepthLink& l : links) {
    std::unique_ptr<ceres::CostFunction> cost(PhotometricDepthResidual::Create(l.residual));
    const double* params[3] = {delta, ab[l.keyframe].data(), &rho0};
    double* jac[3] = {jd, jab, jr};
    if (!cost->Evaluate(params, r, jac)) continue;
    double s2 = 0;
    for (double x : r) s2 += x * x;
    const double w = s2 <= huber * huber ? 1.0 : huber / std::sqrt(s2);
    // The residual depends on the pose and its keyframe's (a, b) only: columns 0-5 and c, c + 1.
    Eigen::Matrix<double, kPatternSize, 8> J;
    for (int p = 0; p < kPatternSize; ++p) {
      for (int j = 0; j < 6; ++j) J(p, j) = jd[p * 6 + j];
      J(p, 6) = jab[p * 2], J(p, 7) = jab[p * 2 + 1];
    }
    const Eigen::Map<const Eigen::Matrix<double, kPatternSize, 1>> Jr(jr);
    const Eigen::Matrix<double, 8, 8> h = w * J.transpose() * J;
    const Eigen::Matrix<double, 8, 6> b = w * (J.transpose() * Jr) * l.D;
    const int c = 6 + 2 * l.keyframe;
    H.topLeftCorner<6, 6>() += h.topLeftCorner<6, 6>();
    H.block<6, 2>(0, c) += h.topRightCorner<6, 2>();
    H.block<2, 6>(c, 0) += h.bottomLeftCorner<2, 6>();
    H.block<2, 2>(c, c) += h.bottomRightCorner<2, 2>();
    B.topRows<6>() += b.topRows<6>();
    B.middleRows<2>(c) += b.bottomRows<2>();
  }
  if (fixed_length_at) {  // the stiff length prior (BaselineLengthPrior) at the solution
    const Eigen::Vector3d t = fixed_length_at->translation();
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    g.segment<3>(3) = kBaselineLengthWeight * t.normalized();
    H += g * g.transpose();
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success) return Matrix6d::Zero();
  const Eigen::MatrixXd S = -ldlt.solve(B);
  if (!S.allFinite()) return Matrix6d::Zero();
  return S.topRows<6>();
}

CameraIntrinsics scaled(const CameraIntrinsics& c, int level, int w, int h) {
  const double s = std::ldexp(1.0, -level);
  CameraIntrinsics o = c;
  o.fx = c.fx * s, o.fy = c.fy * s;
  // The area-average convention (pixel centres at +0.5): cv::pyrDown's is level-L pixel i on
  // level-0 pixel 2^L i, 0.25-0.375 level px off. Both images shift alike, so it cancels to first
  // order; session 33 tried pyrDown's and reverted it (doc/co_calibration.md).
  o.cx = (c.cx + 0.5) * s - 0.5, o.cy = (c.cy + 0.5) * s - 0.5;
  o.width = w, o.height = h;
  return o;
}

}  // namespace

std::vector<KeyPoint> selectKeyPoints(const Keyframe& kf, const MeshDepth& md,
                                      const PhotometricSettings& s) {
  cv::Mat gx, gy;
  cv::Scharr(kf.left_gray, gx, CV_32F, 1, 0, 1.0 / 32);
  cv::Scharr(kf.left_gray, gy, CV_32F, 0, 1, 1.0 / 32);
  // Local depth range (+inf where a face is missing nearby, so such pixels are rejected too).
  cv::Mat zmin, zmax;
  const int r = s.smooth_depth_radius_px;
  if (r > 0) {
    const cv::Mat box = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1));
    cv::erode(md.depth, zmin, box);
    cv::dilate(md.depth, zmax, box);
  }
  std::vector<KeyPoint> out;
  const int c = s.cell_size, border = 8;
  for (int v0 = border; v0 + c <= kf.left_gray.rows - border; v0 += c) {
    for (int u0 = border; u0 + c <= kf.left_gray.cols - border; u0 += c) {
      KeyPoint best;
      for (int v = v0; v < v0 + c; ++v)
        for (int u = u0; u < u0 + c; ++u) {
          const double g2 = double(gx.at<float>(v, u)) * gx.at<float>(v, u) +
                            double(gy.at<float>(v, u)) * gy.at<float>(v, u);
          const int f = md.face_id.at<int>(v, u);
          const float z = md.depth.at<float>(v, u);
          if (f < 0 || z < s.min_depth || z > s.max_depth || g2 <= best.grad2) continue;
          const bool smooth =
              r == 0 || zmax.at<float>(v, u) - zmin.at<float>(v, u) <= s.smooth_depth_tolerance * z;
          if (!smooth) continue;
          best = {double(u), double(v), f, g2};
        }
      if (best.face >= 0 && best.grad2 > s.min_gradient * s.min_gradient) out.push_back(best);
    }
  }
  if (static_cast<int>(out.size()) > s.max_keypoints_per_keyframe) {
    std::vector<KeyPoint> kept;
    // Evenly over the list, exactly max_keypoints_per_keyframe of them (an accumulated
    // floating-point step kept one more now and then).
    const size_t n = out.size(), m = static_cast<size_t>(s.max_keypoints_per_keyframe);
    kept.reserve(m);
    for (size_t k = 0; k < m; ++k) kept.push_back(out[k * n / m]);
    out.swap(kept);
  }
  return out;
}

PhotometricResult solvePhotometric(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar,
                                   const Eigen::Isometry3d& T_init, const PhotometricSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PhotometricResult res;
  res.T_right_left = T_init;
  res.brightness.assign(window.size(), Eigen::Vector2d::Zero());
  if (window.empty()) {
    res.message = "empty window";
    return res;
  }
  const std::string pair_problem = stereoExtrinsicProblem(T_init);
  if (!pair_problem.empty() || !isRigidTransform(T_cam_lidar)) {
    res.message = !pair_problem.empty()
                      ? "initial guess: " + pair_problem
                      : "the LiDAR extrinsic is not a rigid transform (NaN, or not a rotation)";
    return res;
  }
  for (const Keyframe* kf : window)
    if (kf->left_gray.empty() || kf->right_gray.empty() || kf->left_gray.cols != rig.left.width ||
        kf->left_gray.rows != rig.left.height || kf->right_gray.cols != rig.right.width ||
        kf->right_gray.rows != rig.right.height || kf->left_gray.type() != CV_8UC1 ||
        kf->right_gray.type() != CV_8UC1) {
      res.message =
          "a keyframe's images are empty, not 8-bit grey or not of the rig's sizes (left " +
          std::to_string(rig.left.width) + "x" + std::to_string(rig.left.height) + ", right " +
          std::to_string(rig.right.width) + "x" + std::to_string(rig.right.height) + ")";
      return res;
    }
  if (s.cell_size < 1 || s.max_keypoints_per_keyframe < 1 || s.pyramid_levels < 1 ||
      s.iterations_per_level < 1 || s.threads < 1 || s.min_keypoints < 1) {
    res.message =
        "cell_size, max_keypoints_per_keyframe, pyramid_levels, iterations_per_level, threads and "
        "min_keypoints must be at least 1";
    return res;
  }
  // Key points with LiDAR depth (left z-buffer of the mesh), chosen once at full resolution.
  // With smooth_depth_radius_px > 0 the coarse levels still use every key point (depth edges
  // widen the basin) and the full-resolution level only those on smooth LiDAR depth.
  PhotometricSettings all_settings = s;
  all_settings.smooth_depth_radius_px = 0;
  std::vector<std::vector<KeyPoint>> kps(window.size()), kps_all(window.size());
  const int n_kf = static_cast<int>(window.size());
  parallelFor(n_kf, s.threads, [&](int k) {
    const MeshDepth md = renderMeshDepth(window[k]->mesh, T_cam_lidar, rig.left);
    kps[k] = selectKeyPoints(*window[k], md, s);
    kps_all[k] =
        s.smooth_depth_radius_px > 0 ? selectKeyPoints(*window[k], md, all_settings) : kps[k];
  });
  for (const auto& k : kps) res.keypoints += static_cast<int>(k.size());
  if (res.keypoints < s.min_keypoints) {
    res.message = "too few key points with LiDAR depth (" + std::to_string(res.keypoints) + ")";
    return res;
  }
  // Pyramids.
  std::vector<std::vector<Level>> pyr(window.size());
  parallelFor(n_kf, s.threads, [&](int k) {
    cv::Mat l, r;
    window[k]->left_gray.convertTo(l, CV_64F);
    window[k]->right_gray.convertTo(r, CV_64F);
    pyr[k].resize(s.pyramid_levels);
    for (int L = 0; L < s.pyramid_levels; ++L) {
      if (L > 0) {
        cv::pyrDown(l, l);
        cv::pyrDown(r, r);
      }
      Level& lv = pyr[k][L];
      lv.left = l.clone();
      lv.right = r.clone();
      lv.right_data.assign(reinterpret_cast<const double*>(r.data),
                           reinterpret_cast<const double*>(r.data) + r.total());
      lv.grid =
          std::make_unique<ceres::Grid2D<double, 1>>(lv.right_data.data(), 0, r.rows, 0, r.cols);
      lv.interp = std::make_unique<ImageInterpolator>(*lv.grid);
      lv.left_cam = scaled(rig.left, L, l.cols, l.rows);
      lv.right_cam = scaled(rig.right, L, r.cols, r.rows);
    }
  });

  Eigen::Isometry3d T = T_init;
  std::vector<std::array<double, 2>> ab(window.size(), {0.0, 0.0});
  const double c2 = s.gradient_weight_c * s.gradient_weight_c;
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  for (int L = s.pyramid_levels - 1; L >= 0; --L) {
    const double scale = std::ldexp(1.0, -L);
    ceres::Problem problem(po);
    ceres::HuberLoss huber(s.huber);
    double delta[6] = {0, 0, 0, 0, 0, 0};
    int used = 0, occluded = 0;
    const bool free_depth = s.depth_prior_sigma > 0 && L < s.depth_free_levels;
    std::vector<double> rho;  // per key point; never reallocated while the problem holds it
    std::vector<ceres::ResidualBlockId> photometric_blocks;  // for the consistency check
    // The LiDAR extrinsic's error shared by the key points' depths (lidar_error_sigma_*).
    const bool lidar_nuisance =
        free_depth && s.lidar_error_sigma_rot_deg > 0 && s.lidar_error_sigma_trans_m > 0;
    double xi[6] = {0, 0, 0, 0, 0, 0};
    // Cauchy on the depth prior: a key point whose LiDAR depth is off by far more than sigma (a
    // depth edge, the road under a misprojected mesh) leaves the scale to the others.
    ceres::CauchyLoss depth_loss(1.0);
    if (free_depth) {
      size_t n = 0;
      for (size_t k = 0; k < window.size(); ++k) n += (L > 0 ? kps_all[k] : kps[k]).size();
      rho.reserve(n);
    }
    // Full resolution, LiDAR depth: each used key point's residual and how its depth follows the
    // LiDAR extrinsic, for the sensitivity below.
    const bool sensitivity = L == 0 && !free_depth;
    std::vector<DepthLink> links;
    // Visibility in the right camera under the current estimate (rendered in parallel; the
    // residuals are then added in window order).
    std::vector<MeshDepth> right_mds(window.size());
    parallelFor(n_kf, s.threads, [&](int k) {
      right_mds[k] = renderMeshDepth(window[k]->mesh, T * T_cam_lidar, rig.right);
    });
    for (size_t k = 0; k < window.size(); ++k) {
      const Level& lv = pyr[k][L];
      const MeshDepth& right_md = right_mds[k];
      for (const KeyPoint& kp : L > 0 ? kps_all[k] : kps[k]) {
        const MeshFace& f = window[k]->mesh.faces[kp.face];
        Eigen::Vector3d X;
        if (!intersectFace(f, T_cam_lidar, rig.left, kp.u, kp.v, &X)) continue;
        const Visibility vis = visibility(T * X, rig.right, right_md, s.occlusion_tolerance);
        occluded += vis == Visibility::kOccluded;
        if (vis != Visibility::kVisible) continue;
        const double ul = (kp.u + 0.5) * scale - 0.5, vl = (kp.v + 0.5) * scale - 0.5;
        std::array<Eigen::Vector3d, kPatternSize> q;
        std::array<double, kPatternSize> left_value;
        bool ok = true;
        for (int p = 0; p < kPatternSize && ok; ++p) {
          const double pu = ul + kPattern[p][0], pv = vl + kPattern[p][1];
          Eigen::Vector3d Xp;
          ok = intersectFace(f, T_cam_lidar, lv.left_cam, pu, pv, &Xp);
          left_value[p] = bilinear(lv.left, pu, pv);
          ok = ok && std::isfinite(left_value[p]);
          q[p] = T.linear() * Xp;
        }
        if (!ok) continue;
        const double w = c2 / (c2 + kp.grad2);
        const PhotometricResidual r(lv.interp.get(), q, T.translation(), left_value, std::sqrt(w),
                                    lv.right_cam.fx, lv.right_cam.fy, lv.right_cam.cx,
                                    lv.right_cam.cy);
        if (free_depth) {
          rho.push_back(0.0);
          photometric_blocks.push_back(problem.AddResidualBlock(
              PhotometricDepthResidual::Create(r), &huber, delta, ab[k].data(), &rho.back()));
          if (lidar_nuisance)
            problem.AddResidualBlock(
                new ceres::AutoDiffCostFunction<LogDepthLidarPrior, 1, 1, 6>(
                    new LogDepthLidarPrior(depthRow(f, T_cam_lidar, X), s.depth_prior_sigma)),
                &depth_loss, &rho.back(), xi);
          else
            problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LogDepthPrior, 1, 1>(
                                         new LogDepthPrior(s.depth_prior_sigma)),
                                     &depth_loss, &rho.back());
        } else {
          photometric_blocks.push_back(problem.AddResidualBlock(
              new ceres::AutoDiffCostFunction<PhotometricResidual, kPatternSize, 6, 2>(
                  new PhotometricResidual(r)),
              &huber, delta, ab[k].data()));
          if (sensitivity) links.push_back({r, static_cast<int>(k), depthRow(f, T_cam_lidar, X)});
        }
        ++used;
      }
    }
    if (lidar_nuisance && used > 0) {
      Vector6d sigma;
      sigma << Eigen::Vector3d::Constant(s.lidar_error_sigma_rot_deg / kDegPerRad),
          Eigen::Vector3d::Constant(s.lidar_error_sigma_trans_m);
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LidarErrorPrior, 6, 6>(new LidarErrorPrior(sigma)),
          nullptr, xi);
    }
    if (s.fix_baseline_length && used > 0)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<BaselineLengthPrior, 1, 6>(
              new BaselineLengthPrior(T.translation(), T_init.translation().norm())),
          nullptr, delta);
    res.inliers = used;
    res.occluded = occluded;
    if (used < s.min_keypoints) {
      res.message = "too few visible key points at pyramid level " + std::to_string(L);
      res.T_right_left = T;
      return res;
    }
    ceres::Solver::Options opt;
    opt.linear_solver_type = ceres::DENSE_SCHUR;
    opt.max_num_iterations = s.iterations_per_level;
    opt.num_threads = s.threads;
    opt.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    res.iterations += static_cast<int>(summary.iterations.size());
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = delta[i];
    T = perturb(T, d);
    if (lidar_nuisance)
      for (int i = 0; i < 6; ++i) res.lidar_error[i] = xi[i];
    if (L == 0) {
      // Photo-consistency: the median pattern residual at the estimate against the same with
      // the right image looked up a few pixels off (the pose turned about y and x). Texture alone
      // gives a ratio near 1, a photo-consistent pose far less; a pose that matched nothing (a
      // start beyond the basin) can still have a tight covariance from its residuals' curvature.
      ceres::Problem::EvaluateOptions eo;
      eo.residual_blocks = photometric_blocks;
      eo.apply_loss_function = false;
      auto medianNorm = [&]() {
        std::vector<double> rv;
        if (photometric_blocks.empty() || !problem.Evaluate(eo, nullptr, &rv, nullptr, nullptr))
          return std::nan("");
        const int per = static_cast<int>(rv.size() / photometric_blocks.size());
        std::vector<double> norms(photometric_blocks.size());
        for (size_t b = 0; b < norms.size(); ++b)
          norms[b] = Eigen::Map<const Eigen::VectorXd>(rv.data() + b * per, per).norm();
        std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
        return norms[norms.size() / 2];
      };
      const double at_estimate = medianNorm();
      double shifted = 0;
      const double off = 4.0 / rig.right.fx;  // 4 px
      for (int axis : {0, 1})
        for (double sign : {-1.0, 1.0}) {
          delta[axis] += sign * off;
          shifted += 0.25 * medianNorm();
          delta[axis] -= sign * off;
        }
      res.consistency_ratio = at_estimate / shifted;
      const int n = problem.NumResiduals();
      res.final_cost = 2.0 * summary.final_cost / std::max(1, n);
      // Covariance of the pose marginalised over the brightness parameters.
      ceres::Covariance::Options co;
      if (free_depth) {
        co.algorithm_type = ceres::SPARSE_QR;  // thousands of depth corrections
      } else {
        // Rank-deficient (a direction no key point constrains, e.g. a uniform right image: the
        // pose's Jacobian is zero) fails rather than giving that direction variance 0, as a
        // truncated pseudo-inverse (null_space_rank -1) did.
        co.algorithm_type = ceres::DENSE_SVD;
        co.null_space_rank = 0;
      }
      ceres::Covariance cov(co);
      std::vector<std::pair<const double*, const double*>> blocks{{delta, delta}};
      if (cov.Compute(blocks, &problem)) {
        double C[36];
        cov.GetCovarianceBlock(delta, delta, C);
        // Ceres' covariance assumes unit residual variance: scale by the residuals' own.
        const double sigma2 = 2.0 * summary.final_cost /
                              std::max(1, n - 6 - 2 * int(window.size()) - 2 * int(rho.size()));
        for (int i = 0; i < 36; ++i) res.covariance(i / 6, i % 6) = C[i] * sigma2;
        res.covariance_known = true;
      }
      if (sensitivity)
        res.lidar_sensitivity =
            lidarSensitivity(links, delta, ab, s.huber, s.fix_baseline_length ? &T : nullptr);
    }
  }
  res.T_right_left = T;
  for (size_t k = 0; k < window.size(); ++k) res.brightness[k] = {ab[k][0], ab[k][1]};
  if (!res.covariance_known) {
    // The placeholder stays an identity with no flags and no directions (the header's promise).
    res.message =
        "the covariance could not be computed: the key points leave a direction of the pose "
        "unconstrained (a uniform or covered right image?)";
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
  }
  const bool all = trustFlags(res.covariance, s, res.observable);
  res.weak_directions = weakDirections(res.covariance, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  // Ceres' covariance assumes independent pixels; neighbouring key points share interpolation,
  // LiDAR-depth and exposure errors. A per-axis model error, calibrated like the LiDAR one (mean
  // NEES over independent generated windows), is added; the flags above use the statistical part.
  addAxisVariances(&res.covariance, s.model_sigma_rot_deg, s.model_sigma_trans_m);
  const Vector6d corr = poseError(T, T_init);
  if (corr.head<3>().norm() * kDegPerRad > s.max_correction_rot_deg ||
      corr.tail<3>().norm() > s.max_correction_trans_m)
    res.message = "diverged: the correction from the initial guess is implausibly large";
  else if (!(res.consistency_ratio <= s.max_consistency_ratio))
    res.message = "not photo-consistent: the median key point residual is " +
                  std::to_string(res.consistency_ratio) +
                  " of its value with the right image 4 px off (a start beyond the basin?)";
  else if (!all)
    res.message = "the window does not constrain every axis" + weakestClause(res.weak_directions);
  else
    res.converged = true;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

bool trustFlags(const Matrix6d& covariance, const PhotometricSettings& s, bool observable[6]) {
  return axesWithin(covariance, s.max_sigma_rot_deg, s.max_sigma_trans_m, observable);
}

void addLidarUncertainty(PhotometricResult* result, const Matrix6d& cov_cam_lidar) {
  const Matrix6d& S = result->lidar_sensitivity;
  Matrix6d add = S * cov_cam_lidar * S.transpose();
  result->covariance += 0.5 * (add + add.transpose());
}

}  // namespace tescalib
