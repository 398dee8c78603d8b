#include "tescalib/core/solvers/photometric_solver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/solvers/photometric_lidar_sensitivity.h"
#include "tescalib/core/solvers/residuals/baseline_length_prior.h"
#include "tescalib/core/solvers/residuals/photometric_residual.h"
#include "tescalib/core/solvers/residuals/scalar_prior.h"
#include "tescalib/core/solvers/shared_loss_options.h"
#include "tescalib/core/uncertainty/ceres_covariance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

/// One pyramid level of one keyframe: images as doubles for Ceres' interpolator.
struct Level {
  cv::Mat left, right;  ///< CV_64F
  std::vector<double> right_data;
  std::unique_ptr<ceres::Grid2D<double, 1>> grid;
  std::unique_ptr<ImageInterpolator> interp;
  CameraIntrinsics left_cam, right_cam;
};

CameraIntrinsics scaled(const CameraIntrinsics& c, int level, int w, int h) {
  const double s = std::ldexp(1.0, -level);
  CameraIntrinsics o = c;
  o.fx = c.fx * s, o.fy = c.fy * s;
  // The area-average convention (pixel centres at +0.5): cv::pyrDown's is level-L pixel i on
  // level-0 pixel 2^L i, 0.25-0.375 level px off. Both images shift alike, so either cancels to
  // first order.
  o.cx = (c.cx + 0.5) * s - 0.5, o.cy = (c.cy + 0.5) * s - 0.5;
  o.width = w, o.height = h;
  return o;
}

/// Why the inputs give no solve ("" when they do): the window, the initial guess, the LiDAR
/// extrinsic, the keyframes' images and the settings' ranges.
std::string inputProblem(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                         const Eigen::Isometry3d& T_cam_lidar, const Eigen::Isometry3d& T_init,
                         const PhotometricSettings& s) {
  if (window.empty()) return "empty window";
  const std::string pair_problem = stereoExtrinsicProblem(T_init);
  if (!pair_problem.empty()) return "initial guess: " + pair_problem;
  if (!isRigidTransform(T_cam_lidar))
    return "the LiDAR extrinsic is not a rigid transform (NaN, or not a rotation)";
  for (const Keyframe* kf : window)
    if (kf->left_gray.empty() || kf->right_gray.empty() || kf->left_gray.cols != rig.left.width ||
        kf->left_gray.rows != rig.left.height || kf->right_gray.cols != rig.right.width ||
        kf->right_gray.rows != rig.right.height || kf->left_gray.type() != CV_8UC1 ||
        kf->right_gray.type() != CV_8UC1)
      return "a keyframe's images are empty, not 8-bit grey or not of the rig's sizes (left " +
             std::to_string(rig.left.width) + "x" + std::to_string(rig.left.height) + ", right " +
             std::to_string(rig.right.width) + "x" + std::to_string(rig.right.height) + ")";
  if (s.cell_size < 1 || s.max_keypoints_per_keyframe < 1 || s.pyramid_levels < 1 ||
      s.iterations_per_level < 1 || s.threads < 1 || s.min_keypoints < 1)
    return "cell_size, max_keypoints_per_keyframe, pyramid_levels, iterations_per_level, threads "
           "and min_keypoints must be at least 1";
  return "";
}

/// What every pyramid level of one solve shares: the window, its key points and image pyramids.
struct PhotometricWindow {
  const std::vector<const Keyframe*>& window;
  const StereoRig& rig;
  const Eigen::Isometry3d& T_cam_lidar;
  const PhotometricSettings& s;
  /// Per keyframe: the full-resolution level's key points, and the coarser levels' (every key
  /// point, also off smooth LiDAR depth; the same list when smooth_depth_radius_px is 0).
  std::vector<std::vector<KeyPoint>> kps, kps_all;
  std::vector<std::vector<Level>> pyr;  ///< per keyframe, per level

  int size() const { return static_cast<int>(window.size()); }
  const std::vector<KeyPoint>& keyPoints(size_t k, int level) const {
    return level > 0 ? kps_all[k] : kps[k];
  }
};

/// Key points with LiDAR depth (left z-buffer of the mesh), chosen once at full resolution.
/// With smooth_depth_radius_px > 0 the coarse levels still use every key point (depth edges
/// widen the basin) and the full-resolution level only those on smooth LiDAR depth.
void selectWindowKeyPoints(PhotometricWindow* w) {
  const PhotometricSettings& s = w->s;
  PhotometricSettings all_settings = s;
  all_settings.smooth_depth_radius_px = 0;
  w->kps.assign(w->window.size(), {});
  w->kps_all.assign(w->window.size(), {});
  parallelFor(w->size(), s.threads, [&](int k) {
    const MeshDepth md = renderMeshDepth(w->window[k]->mesh, w->T_cam_lidar, w->rig.left);
    w->kps[k] = selectKeyPoints(*w->window[k], md, s);
    w->kps_all[k] =
        s.smooth_depth_radius_px > 0 ? selectKeyPoints(*w->window[k], md, all_settings) : w->kps[k];
  });
}

/// Each keyframe's image pyramid (pyramid_levels levels, cv::pyrDown) with the scaled intrinsics.
void buildPyramids(PhotometricWindow* w) {
  const PhotometricSettings& s = w->s;
  w->pyr.resize(w->window.size());
  parallelFor(w->size(), s.threads, [&](int k) {
    cv::Mat l, r;
    w->window[k]->left_gray.convertTo(l, CV_64F);
    w->window[k]->right_gray.convertTo(r, CV_64F);
    w->pyr[k].resize(s.pyramid_levels);
    for (int L = 0; L < s.pyramid_levels; ++L) {
      if (L > 0) {
        cv::pyrDown(l, l);
        cv::pyrDown(r, r);
      }
      Level& lv = w->pyr[k][L];
      lv.left = l.clone();
      lv.right = r.clone();
      lv.right_data.assign(reinterpret_cast<const double*>(r.data),
                           reinterpret_cast<const double*>(r.data) + r.total());
      lv.grid =
          std::make_unique<ceres::Grid2D<double, 1>>(lv.right_data.data(), 0, r.rows, 0, r.cols);
      lv.interp = std::make_unique<ImageInterpolator>(*lv.grid);
      lv.left_cam = scaled(w->rig.left, L, l.cols, l.rows);
      lv.right_cam = scaled(w->rig.right, L, r.cols, r.rows);
    }
  });
}

/// The photometric problem of one pyramid level (paper eq. Photometric_object_function):
/// T_right_left = perturb(T, delta), per keyframe (a, b); with free depth a log-depth
/// correction per key point and, with the LiDAR error nuisance, xi shared by them.
struct LevelProblem {
  LevelProblem(const PhotometricSettings& s, int L)
      : level(L),
        scale(std::ldexp(1.0, -L)),
        free_depth(s.depth_prior_sigma > 0 && L < s.depth_free_levels),
        lidar_nuisance(free_depth && s.lidar_error_sigma_rot_deg > 0 &&
                       s.lidar_error_sigma_trans_m > 0),
        sensitivity(L == 0 && !free_depth),
        problem(sharedLossProblemOptions()),
        huber(s.huber) {}

  const int level;
  const double scale;  ///< of the level's pixels to full resolution's
  const bool free_depth;
  /// The LiDAR extrinsic's error shared by the key points' depths (lidar_error_sigma_*).
  const bool lidar_nuisance;
  /// Full resolution, LiDAR depth: each used key point's residual and how its depth follows the
  /// LiDAR extrinsic are kept (`links`) for PhotometricResult::lidar_sensitivity.
  const bool sensitivity;
  ceres::Problem problem;
  ceres::HuberLoss huber;
  // Cauchy on the depth prior: a key point whose LiDAR depth is off by far more than sigma (a
  // depth edge, the road under a misprojected mesh) leaves the scale to the others.
  ceres::CauchyLoss depth_loss{1.0};
  double delta[6] = {0, 0, 0, 0, 0, 0};
  double xi[6] = {0, 0, 0, 0, 0, 0};
  std::vector<double> rho;  ///< per key point; never reallocated while the problem holds it
  std::vector<ceres::ResidualBlockId> photometric_blocks;  ///< for the consistency check
  std::vector<DepthLink> links;
  int used = 0, occluded = 0;
};

/// The pattern residual of key point `kp` on face `f` at pyramid level `lv`: each pattern
/// pixel's point is where its left ray meets the face (eq. parametric_equation), rotated by the
/// current estimate `T`; none when a ray misses the face or a pixel the left image.
std::optional<PhotometricResidual> patternResidual(const KeyPoint& kp, const MeshFace& f,
                                                   const Level& lv, const LevelProblem& lp,
                                                   const Eigen::Isometry3d& T_cam_lidar,
                                                   const Eigen::Isometry3d& T, double c2) {
  const double ul = (kp.u + 0.5) * lp.scale - 0.5, vl = (kp.v + 0.5) * lp.scale - 0.5;
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
  if (!ok) return std::nullopt;
  const double w = c2 / (c2 + kp.grad2);
  return PhotometricResidual(lv.interp.get(), q, T.translation(), left_value, std::sqrt(w),
                             lv.right_cam.fx, lv.right_cam.fy, lv.right_cam.cx, lv.right_cam.cy);
}

/// Adds a key point's residual blocks: the photometric one and, with free depth, its log-depth
/// correction's prior (anchored on the LiDAR nuisance when there is one). `X`: its point on
/// face `f` (left camera frame), `k`: its keyframe.
void addKeyPoint(LevelProblem* lp, const PhotometricResidual& r, const MeshFace& f,
                 const Eigen::Vector3d& X, size_t k, const Eigen::Isometry3d& T_cam_lidar,
                 const PhotometricSettings& s, std::array<double, 2>* ab) {
  ceres::Problem& problem = lp->problem;
  if (lp->free_depth) {
    lp->rho.push_back(0.0);
    double* rho = &lp->rho.back();
    lp->photometric_blocks.push_back(problem.AddResidualBlock(
        PhotometricDepthResidual::Create(r), &lp->huber, lp->delta, ab->data(), rho));
    if (lp->lidar_nuisance)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LogDepthLidarPrior, 1, 1, 6>(
              new LogDepthLidarPrior(depthRow(f, T_cam_lidar, X), s.depth_prior_sigma)),
          &lp->depth_loss, rho, lp->xi);
    else
      problem.AddResidualBlock(ScalarPrior::Create(s.depth_prior_sigma), &lp->depth_loss, rho);
  } else {
    lp->photometric_blocks.push_back(problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<PhotometricResidual, kPatternSize, 6, 2>(
            new PhotometricResidual(r)),
        &lp->huber, lp->delta, ab->data()));
    if (lp->sensitivity) lp->links.push_back({r, static_cast<int>(k), depthRow(f, T_cam_lidar, X)});
  }
  ++lp->used;
}

/// Adds every key point of the window that the right camera sees under the current estimate `T`
/// (key point projection through the LiDAR mesh, eq. affine_transformation).
void addKeyPoints(LevelProblem* lp, const PhotometricWindow& w, const Eigen::Isometry3d& T,
                  std::vector<std::array<double, 2>>* ab) {
  const PhotometricSettings& s = w.s;
  const double c2 = s.gradient_weight_c * s.gradient_weight_c;
  if (lp->free_depth) {
    size_t n = 0;
    for (size_t k = 0; k < w.window.size(); ++k) n += w.keyPoints(k, lp->level).size();
    lp->rho.reserve(n);
  }
  // Visibility in the right camera under the current estimate (rendered in parallel; the
  // residuals are then added in window order).
  std::vector<MeshDepth> right_mds(w.window.size());
  parallelFor(w.size(), s.threads, [&](int k) {
    right_mds[k] = renderMeshDepth(w.window[k]->mesh, T * w.T_cam_lidar, w.rig.right);
  });
  for (size_t k = 0; k < w.window.size(); ++k) {
    const Level& lv = w.pyr[k][lp->level];
    for (const KeyPoint& kp : w.keyPoints(k, lp->level)) {
      const MeshFace& f = w.window[k]->mesh.faces[kp.face];
      Eigen::Vector3d X;
      if (!intersectFace(f, w.T_cam_lidar, w.rig.left, kp.u, kp.v, &X)) continue;
      const Visibility vis = visibility(T * X, w.rig.right, right_mds[k], s.occlusion_tolerance);
      lp->occluded += vis == Visibility::kOccluded;
      if (vis != Visibility::kVisible) continue;
      const std::optional<PhotometricResidual> r =
          patternResidual(kp, f, lv, *lp, w.T_cam_lidar, T, c2);
      if (r) addKeyPoint(lp, *r, f, X, k, w.T_cam_lidar, s, &(*ab)[k]);
    }
  }
}

/// The priors on the level's shared parameters: the LiDAR error nuisance's and, with
/// fix_baseline_length, the stiff baseline length (the initial guess').
void addPriors(LevelProblem* lp, const PhotometricSettings& s, const Eigen::Isometry3d& T,
               const Eigen::Isometry3d& T_init) {
  if (lp->lidar_nuisance && lp->used > 0) {
    Vector6d sigma;
    sigma << Eigen::Vector3d::Constant(s.lidar_error_sigma_rot_deg / kDegPerRad),
        Eigen::Vector3d::Constant(s.lidar_error_sigma_trans_m);
    lp->problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LidarErrorPrior, 6, 6>(new LidarErrorPrior(sigma)), nullptr,
        lp->xi);
  }
  if (s.fix_baseline_length && lp->used > 0)
    lp->problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<BaselineLengthPrior, 1, 6>(
            new BaselineLengthPrior(T.translation(), T_init.translation().norm())),
        nullptr, lp->delta);
}

ceres::Solver::Summary solveLevel(ceres::Problem* problem, const PhotometricSettings& s) {
  ceres::Solver::Options opt;
  opt.linear_solver_type = ceres::DENSE_SCHUR;
  opt.max_num_iterations = s.iterations_per_level;
  opt.num_threads = s.threads;
  opt.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(opt, problem, &summary);
  return summary;
}

/// The median norm of the photometric blocks' residuals (no loss) at the problem's parameters.
double medianBlockNorm(LevelProblem* lp) {
  const std::vector<ceres::ResidualBlockId>& blocks = lp->photometric_blocks;
  ceres::Problem::EvaluateOptions eo;
  eo.residual_blocks = blocks;
  eo.apply_loss_function = false;
  std::vector<double> rv;
  if (blocks.empty() || !lp->problem.Evaluate(eo, nullptr, &rv, nullptr, nullptr))
    return std::nan("");
  const int per = static_cast<int>(rv.size() / blocks.size());
  std::vector<double> norms(blocks.size());
  for (size_t b = 0; b < norms.size(); ++b)
    norms[b] = Eigen::Map<const Eigen::VectorXd>(rv.data() + b * per, per).norm();
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
  return norms[norms.size() / 2];
}

/// Photo-consistency: the median pattern residual at the estimate against the same with the
/// right image looked up a few pixels off (the pose turned about y and x). Texture alone gives a
/// ratio near 1, a photo-consistent pose far less; a pose that matched nothing (a start beyond
/// the basin) can still have a tight covariance from its residuals' curvature.
double consistencyRatio(LevelProblem* lp, double right_fx) {
  const double at_estimate = medianBlockNorm(lp);
  double shifted = 0;
  const double off = 4.0 / right_fx;  // 4 px
  for (int axis : {0, 1})
    for (double sign : {-1.0, 1.0}) {
      lp->delta[axis] += sign * off;
      shifted += 0.25 * medianBlockNorm(lp);
      lp->delta[axis] -= sign * off;
    }
  return at_estimate / shifted;
}

/// Covariance of the pose marginalised over the brightness parameters (and free depths), scaled
/// by the residuals' variance; sets covariance and covariance_known when Ceres gives one.
void poseCovariance(LevelProblem* lp, double final_cost, int keyframes, PhotometricResult* res) {
  ceres::Covariance::Options co;
  if (lp->free_depth) {
    co.algorithm_type = ceres::SPARSE_QR;  // thousands of depth corrections
  } else {
    // Rank-deficient (a direction no key point constrains, e.g. a uniform right image: the
    // pose's Jacobian is zero) fails rather than giving that direction variance 0, as a
    // truncated pseudo-inverse (null_space_rank -1) would.
    co.algorithm_type = ceres::DENSE_SVD;
    co.null_space_rank = 0;
  }
  std::vector<RowMajorMatrixXd> c;
  if (!blockCovariances(&lp->problem, {lp->delta}, co, &c)) return;
  // Ceres' covariance assumes unit residual variance: scale by the residuals' own.
  const double sigma2 = residualVariance(final_cost, lp->problem.NumResiduals(),
                                         6 + 2 * keyframes + 2 * static_cast<int>(lp->rho.size()));
  res->covariance = c[0] * sigma2;
  res->covariance_known = true;
}

/// What the full-resolution level adds to the result: the photo-consistency ratio, the mean cost,
/// the covariance and the sensitivity to the LiDAR extrinsic, at the estimate `T`.
void fullResolutionUncertainty(LevelProblem* lp, const ceres::Solver::Summary& summary,
                               const PhotometricWindow& w, const Eigen::Isometry3d& T,
                               const std::vector<std::array<double, 2>>& ab,
                               PhotometricResult* res) {
  res->consistency_ratio = consistencyRatio(lp, w.rig.right.fx);
  const int n = lp->problem.NumResiduals();
  res->final_cost = 2.0 * summary.final_cost / std::max(1, n);
  poseCovariance(lp, summary.final_cost, w.size(), res);
  if (lp->sensitivity)
    res->lidar_sensitivity = lidarSensitivity(lp->links, lp->delta, ab, w.s.huber,
                                              w.s.fix_baseline_length ? &T : nullptr);
}

/// The trust flags, weak directions and model error of a solve with a covariance, and its
/// verdict: converged, or why not (diverged, not photo-consistent, an unconstrained direction).
void judge(const Eigen::Isometry3d& T_init, const PhotometricSettings& s, PhotometricResult* res) {
  const bool all = trustFlags(res->covariance, s, res->observable);
  res->weak_directions = weakDirections(res->covariance, s.max_sigma_rot_deg, s.max_sigma_trans_m);
  // Ceres' covariance assumes independent pixels; neighbouring key points share interpolation,
  // LiDAR-depth and exposure errors. A per-axis model error, calibrated like the LiDAR one (mean
  // NEES over independent generated windows), is added; the flags above use the statistical part.
  addAxisVariances(&res->covariance, s.model_sigma_rot_deg, s.model_sigma_trans_m);
  const Vector6d corr = poseError(res->T_right_left, T_init);
  if (corr.head<3>().norm() * kDegPerRad > s.max_correction_rot_deg ||
      corr.tail<3>().norm() > s.max_correction_trans_m)
    res->message = "diverged: the correction from the initial guess is implausibly large";
  else if (!(res->consistency_ratio <= s.max_consistency_ratio))
    res->message = "not photo-consistent: the median key point residual is " +
                   std::to_string(res->consistency_ratio) +
                   " of its value with the right image 4 px off (a start beyond the basin?)";
  else if (!all)
    res->message = "the window does not constrain every axis" + weakestClause(res->weak_directions);
  else
    res->converged = true;
}

}  // namespace

PhotometricResult solvePhotometric(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar,
                                   const Eigen::Isometry3d& T_init, const PhotometricSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PhotometricResult res;
  res.T_right_left = T_init;
  res.brightness.assign(window.size(), Eigen::Vector2d::Zero());
  res.message = inputProblem(window, rig, T_cam_lidar, T_init, s);
  if (!res.message.empty()) return res;
  PhotometricWindow w{window, rig, T_cam_lidar, s, {}, {}, {}};
  selectWindowKeyPoints(&w);
  for (const auto& k : w.kps) res.keypoints += static_cast<int>(k.size());
  if (res.keypoints < s.min_keypoints) {
    res.message = "too few key points with LiDAR depth (" + std::to_string(res.keypoints) + ")";
    return res;
  }
  buildPyramids(&w);
  // Coarse to fine, each level's problem built at the previous level's estimate.
  Eigen::Isometry3d T = T_init;
  std::vector<std::array<double, 2>> ab(window.size(), {0.0, 0.0});
  for (int L = s.pyramid_levels - 1; L >= 0; --L) {
    LevelProblem lp(s, L);
    addKeyPoints(&lp, w, T, &ab);
    addPriors(&lp, s, T, T_init);
    res.inliers = lp.used;
    res.occluded = lp.occluded;
    if (lp.used < s.min_keypoints) {
      res.message = "too few visible key points at pyramid level " + std::to_string(L);
      res.T_right_left = T;
      return res;
    }
    const ceres::Solver::Summary summary = solveLevel(&lp.problem, s);
    res.iterations += static_cast<int>(summary.iterations.size());
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = lp.delta[i];
    T = perturb(T, d);
    if (lp.lidar_nuisance)
      for (int i = 0; i < 6; ++i) res.lidar_error[i] = lp.xi[i];
    if (L == 0) fullResolutionUncertainty(&lp, summary, w, T, ab, &res);
  }
  res.T_right_left = T;
  for (size_t k = 0; k < window.size(); ++k) res.brightness[k] = {ab[k][0], ab[k][1]};
  if (!res.covariance_known) {
    // The placeholder stays an identity with no flags and no directions (the header's promise).
    res.message =
        "the covariance could not be computed: the key points leave a direction of the pose "
        "unconstrained (a uniform or covered right image?)";
  } else {
    judge(T_init, s, &res);
  }
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
