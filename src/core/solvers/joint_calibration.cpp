#include "tescalib/core/solvers/joint_calibration.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/solvers/joint_covariance.h"
#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/solvers/residuals/joint_residuals.h"
#include "tescalib/core/solvers/residuals/point_plane_distance.h"
#include "tescalib/core/solvers/shared_loss_options.h"

namespace tescalib {
namespace {

/// A keyframe's images as doubles, the right one for Ceres' interpolator.
struct Images {
  cv::Mat left;  ///< CV_64F
  std::vector<double> right_data;
  std::unique_ptr<ceres::Grid2D<double, 1>> grid;
  std::unique_ptr<ImageInterpolator> interp;
};

double normalisedStep(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                      const CoCalibrationSettings& s) {
  const Vector6d d = poseError(a, b);
  return std::max(d.head<3>().norm() * kDegPerRad / s.stable_rot_deg,
                  d.tail<3>().norm() / s.stable_trans_m);
}

/// A result that only says why the joint solve did not run, the initial guesses its estimates.
CoCalibrationResult refusal(const Eigen::Isometry3d& T_cam_lidar_init,
                            const Eigen::Isometry3d& T_right_left_init, const std::string& why) {
  CoCalibrationResult res;
  res.lidar.T_cam_lidar = T_cam_lidar_init;
  res.stereo.T_right_left = T_right_left_init;
  res.message = why;
  return res;
}

/// Why the window's meshes cannot carry the photometric residuals ("" when they can): key points
/// lie on any face, whose normal must be fitted.
std::string meshProblem(const std::vector<Keyframe*>& window) {
  for (size_t k = 0; k < window.size(); ++k) {
    const LidarMesh& m = window[k]->mesh;
    if (m.sample.size() == m.faces.size()) continue;
    return "joint calibration needs every face's normal fitted (LidarMeshSettings::"
           "sampled_faces = 0): keyframe " +
           std::to_string(k) + "'s mesh has " + std::to_string(m.sample.size()) + " of " +
           std::to_string(m.faces.size());
  }
  return "";
}

/// Alternation rounds until one included a photometric solve (its key points, brightness and
/// cost set up the joint problem): with stereo_from_features, round 1 takes the pair from
/// feature matches and solves LiDAR-stereo with the wide-basin search, round 2 is photometric.
/// The alternation's own bookkeeping is reset: it does not describe the joint result
/// (`features`, `rectifications` and `rematches` do: they count the whole solve).
CoCalibrationResult initialRounds(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                  const Eigen::Isometry3d& T_cam_lidar_init,
                                  const Eigen::Isometry3d& T_right_left_init,
                                  const CoCalibrationSettings& s) {
  CoCalibrationSettings init = s;
  init.max_rounds = s.stereo_from_features ? 2 : 1;
  init.extrapolate = false;
  // Nothing of what the alternation does at its end or between its rounds for its own result:
  // no yaw handover (in round 2 it restarts the LiDAR at the initial guess, and the rounds end
  // there), no split-window check, no sensitivity to the pair, no second opinion (the joint
  // estimate gets its covariances from the solves at it, joint_covariance.h).
  init.yaw_handover_deg = -1;
  init.lidar.check_window_halves = false;
  init.propagate_stereo_into_lidar = false;
  init.confirm_beyond_deg = init.confirm_beyond_m = -1;
  CoCalibrationResult res = coCalibrate(window, rig, T_cam_lidar_init, T_right_left_init, init);
  res.stable = res.converged = false;
  res.rounds = 0;
  res.extrapolations = res.rejected = res.yaw_handovers = 0;
  res.lidar_first = false;
  res.lidar_stereo_sensitivity.setZero();
  res.coupling = 0;
  return res;
}

/// Why the initial rounds leave the joint problem nothing to start from ("" when they do not):
/// too few key points or LiDAR residuals, or a pair the clouds cannot be rectified with (the
/// round said why: coCalibrate's message `init_message`).
std::string initialRoundFailure(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const CoCalibrationResult& res, const std::string& init_message,
                                const CoCalibrationSettings& s) {
  const bool unusable_pair =
      !window.empty() && rectifiedBaseline(rig, res.stereo.T_right_left) <= 0;
  if (!(window.empty() || res.stereo.keypoints < s.stereo.min_keypoints ||
        res.stereo.brightness.size() != window.size() ||
        res.lidar.fine_inliers < s.lidar.min_inliers || unusable_pair))
    return "";
  return "initial round failed: " +
         (window.empty() ? std::string("empty window")
          : unusable_pair || (res.stereo.message.empty() && res.lidar.message.empty())
              ? init_message
              : res.stereo.message + " / " + res.lidar.message);
}

/// The joint problem's state across outer iterations: both estimates, the photometric sigma that
/// weighs the photometric residuals against the LiDAR ones, the per-keyframe brightness, and the
/// photometric half's fixed inputs (key points chosen once, with the initial rounds' LiDAR
/// extrinsic, and the images).
struct JointState {
  Eigen::Isometry3d T_cl, T_rl;
  double sigma_ph = 1;
  std::vector<std::vector<KeyPoint>> kps;
  std::vector<Images> img;
  std::vector<std::array<double, 2>> ab;
};

void initJointState(const std::vector<Keyframe*>& window, const StereoRig& rig,
                    const CoCalibrationResult& res, const JointCalibrationSettings& js,
                    JointState* st) {
  st->T_cl = res.lidar.T_cam_lidar, st->T_rl = res.stereo.T_right_left;
  st->sigma_ph = js.photometric_sigma > 0 ? js.photometric_sigma
                                          : std::sqrt(std::max(1.0, res.stereo.final_cost));
  st->kps.resize(window.size());
  st->img.resize(window.size());
  for (size_t k = 0; k < window.size(); ++k) {
    st->kps[k] = selectKeyPoints(*window[k], renderMeshDepth(window[k]->mesh, st->T_cl, rig.left),
                                 js.co.stereo);
    Images& img = st->img[k];
    window[k]->left_gray.convertTo(img.left, CV_64F);
    cv::Mat r;
    window[k]->right_gray.convertTo(r, CV_64F);
    img.right_data.assign(reinterpret_cast<const double*>(r.data),
                          reinterpret_cast<const double*>(r.data) + r.total());
    img.grid =
        std::make_unique<ceres::Grid2D<double, 1>>(img.right_data.data(), 0, r.rows, 0, r.cols);
    img.interp = std::make_unique<ImageInterpolator>(*img.grid);
  }
  st->ab.resize(window.size());
  for (size_t k = 0; k < window.size(); ++k)
    st->ab[k] = {res.stereo.brightness[k].x(), res.stereo.brightness[k].y()};
}

/// One outer iteration's problem over both extrinsics' corrections (and the brightness).
struct JointProblem {
  JointProblem(const CoCalibrationSettings& s, double sigma_ph)
      : problem(sharedLossProblemOptions()),
        lidar_loss(s.lidar.fine_huber),
        photo_loss(s.stereo.huber / sigma_ph) {}
  double d_cl[6] = {0, 0, 0, 0, 0, 0}, d_rl[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem problem;
  ceres::HuberLoss lidar_loss, photo_loss;
};

/// LiDAR-stereo fine residuals (JointLidarResidual): projective association of each sampled face
/// with its keyframe's stereo cloud at the current estimate; returns how many.
int addLidarResiduals(JointProblem* jp, const std::vector<Keyframe*>& window, const JointState& st,
                      const CoCalibrationSettings& s) {
  const LidarStereoSettings& ls = s.lidar;
  const Eigen::Isometry3d &T_cl = st.T_cl, &T_rl = st.T_rl;
  int n_lidar = 0;
  const Eigen::Matrix3d R = T_cl.linear();
  for (size_t k = 0; k < window.size(); ++k) {
    const StereoCloud& sc = window[k]->stereo;
    // Per keyframe: the clouds need not share one rectification (rectifyWindow leaves a cloud
    // within its tolerances as it is; online windows mix clouds built at different estimates).
    const Eigen::Isometry3d& used = window[k]->T_right_left_used;
    const double b_used = used.translation().norm();
    const double scale = T_rl.translation().norm() / b_used;
    const Eigen::Vector3d phi0 = logSO3(T_rl.linear() * used.linear().transpose());
    for (size_t fi : sampleFaces(window[k]->mesh, ls.fine_faces_per_keyframe)) {
      const MeshFace& f = window[k]->mesh.faces[fi];
      const Eigen::Vector3d q = R * f.centroid.cast<double>();
      const Eigen::Vector3d c = q + T_cl.translation();
      const Eigen::Vector3d pr = sc.R_rect_left * c;
      if (pr.z() < 1.0 || pr.z() > ls.max_depth) continue;
      const Eigen::Vector2d px = projectPinhole(sc.fx, sc.fy, sc.cx, sc.cy, pr);
      const double u = px.x(), v = px.y();
      double d;
      if (!sc.disparityAt(u, v, &d)) continue;
      const Eigen::Vector3d p_s = sc.pointAt(u, v, d);
      Eigen::Vector3d m = R * f.normal.cast<double>();
      const double inv_sigma = pointPlaneInvSigma(m, c.normalized(), f.range, p_s, d, scale,
                                                  s.stereo_cloud.disparity_sigma, ls);
      if (std::fabs(m.dot(c - scale * p_s)) * inv_sigma > ls.fine_gate_sigma) continue;
      fineResidualNormal(sc, u, v, s.fine_stereo_normal_px, c.normalized(), &m);
      auto* lr = new JointLidarResidual;
      lr->q = q, lr->m = m, lr->t = T_cl.translation();
      lr->u = u, lr->v = v, lr->d = d;
      lr->fx = sc.fx, lr->fy = sc.fy, lr->cx = sc.cx, lr->cy = sc.cy;
      lr->R_rect = sc.R_rect_left;
      lr->t_rl = T_rl.translation();
      lr->phi0 = phi0;
      lr->inv_sigma = inv_sigma;
      jp->problem.AddResidualBlock(new ceres::AutoDiffCostFunction<JointLidarResidual, 1, 6, 6>(lr),
                                   &jp->lidar_loss, jp->d_cl, jp->d_rl);
      ++n_lidar;
    }
  }
  return n_lidar;
}

/// The photometric residual of key point `kp` on face `f` (JointPhotometricResidual: its pattern
/// rays meet the face as it moves with T_cam_lidar); null when a pattern pixel is off the image.
JointPhotometricResidual* jointPhotometricResidual(const KeyPoint& kp, const MeshFace& f,
                                                   const Images& img, const StereoRig& rig,
                                                   const JointState& st, double c2) {
  auto* r = new JointPhotometricResidual;
  r->right = img.interp.get();
  bool ok = true;
  for (int p = 0; p < kPatternSize && ok; ++p) {
    const double pu = kp.u + kPattern[p][0], pv = kp.v + kPattern[p][1];
    r->rays[p] = {(pu - rig.left.cx) / rig.left.fx, (pv - rig.left.cy) / rig.left.fy, 1.0};
    r->left[p] = bilinear(img.left, pu, pv);
    ok = std::isfinite(r->left[p]);
  }
  if (!ok) {
    delete r;
    return nullptr;
  }
  const Eigen::Matrix3d R = st.T_cl.linear();
  r->q_f = R * f.centroid.cast<double>();
  r->m_f = R * f.normal.cast<double>();
  r->t_cl = st.T_cl.translation();
  r->R_rl = st.T_rl.linear();
  r->t_rl = st.T_rl.translation();
  // The 8 pattern pixels of a key point share its depth and most of its information: they
  // count as one observation against the LiDAR residuals (each is one face).
  r->sqrt_w = std::sqrt(c2 / (c2 + kp.grad2) / kPatternSize) / st.sigma_ph;
  r->fx = rig.right.fx, r->fy = rig.right.fy, r->cx = rig.right.cx, r->cy = rig.right.cy;
  return r;
}

/// Photometric residuals at full resolution of the key points visible in the right image at the
/// current estimate; returns how many.
int addPhotometricResiduals(JointProblem* jp, const std::vector<Keyframe*>& window,
                            const StereoRig& rig, const PhotometricSettings& ps, JointState* st) {
  const double c2 = ps.gradient_weight_c * ps.gradient_weight_c;
  int n_photo = 0;
  for (size_t k = 0; k < window.size(); ++k) {
    const MeshDepth right_md = renderMeshDepth(window[k]->mesh, st->T_rl * st->T_cl, rig.right);
    for (const KeyPoint& kp : st->kps[k]) {
      const MeshFace& f = window[k]->mesh.faces[kp.face];
      Eigen::Vector3d X;
      if (!intersectFace(f, st->T_cl, rig.left, kp.u, kp.v, &X)) continue;
      if (visibility(st->T_rl * X, rig.right, right_md, ps.occlusion_tolerance) !=
          Visibility::kVisible)
        continue;
      JointPhotometricResidual* r = jointPhotometricResidual(kp, f, st->img[k], rig, *st, c2);
      if (!r) continue;
      jp->problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<JointPhotometricResidual, kPatternSize, 6, 2, 6>(r),
          &jp->photo_loss, jp->d_rl, st->ab[k].data(), jp->d_cl);
      ++n_photo;
    }
  }
  return n_photo;
}

/// Solves one outer iteration's problem and moves both estimates; returns the update in units of
/// the stable tolerances (below 1: stable).
double solveAndUpdate(JointProblem* jp, const JointCalibrationSettings& js, JointState* st,
                      ceres::Solver::Summary* summary) {
  ceres::Solver::Options opt;
  opt.linear_solver_type = ceres::DENSE_SCHUR;
  opt.max_num_iterations = js.ceres_iterations;
  opt.num_threads = js.co.lidar.threads;
  opt.logging_type = ceres::SILENT;
  ceres::Solve(opt, &jp->problem, summary);
  Vector6d dc, dr;
  for (int i = 0; i < 6; ++i) dc[i] = jp->d_cl[i], dr[i] = jp->d_rl[i];
  const Eigen::Isometry3d T_cl_new = perturb(st->T_cl, dc), T_rl_new = perturb(st->T_rl, dr);
  const double step = std::max(normalisedStep(T_cl_new, st->T_cl, js.co),
                               normalisedStep(T_rl_new, st->T_rl, js.co));
  st->T_cl = T_cl_new, st->T_rl = T_rl_new;
  return step;
}

/// The joint outer iterations: re-rectify when the left-right rotation or direction moved enough
/// to matter, associate, one joint solve of both extrinsics; until the update is below the stable
/// tolerances (res->stable), max_outer iterations (res->rounds) or a reason to stop
/// (res->message).
void outerIterations(const std::vector<Keyframe*>& window, const StereoRig& rig,
                     const JointCalibrationSettings& js, bool debug, JointState* st,
                     CoCalibrationResult* res) {
  const CoCalibrationSettings& s = js.co;
  for (res->rounds = 1; res->rounds <= js.max_outer; ++res->rounds) {
    if (s.lidar.cancelled()) {  // LidarStereoSettings::cancel, as coCalibrate honours it
      res->message = "cancelled";
      break;
    }
    if (rectifiedBaseline(rig, st->T_rl) <= 0) {
      res->message = "the left-right estimate of outer iteration " + std::to_string(res->rounds) +
                     " cannot be rectified side by side (its baseline turned away from -x)";
      break;
    }
    RectifyTolerances tol = rectifyTolerances(s);
    tol.direction_deg = tol.yaw_deg = -1.0;  // the joint problem has no yaw nuisance
    res->rectifications += rectifyWindow(window, rig, st->T_rl, s.stereo_cloud, tol,
                                         &res->seconds_stereo_cloud, &res->rematches) > 0;
    JointProblem jp(s, st->sigma_ph);
    const int n_lidar = addLidarResiduals(&jp, window, *st, s);
    const int n_photo = addPhotometricResiduals(&jp, window, rig, s.stereo, st);
    res->lidar.fine_inliers = n_lidar;
    res->stereo.inliers = n_photo;
    if (n_lidar < s.lidar.min_inliers || n_photo < s.stereo.min_keypoints) {
      res->message = "too few residuals (LiDAR " + std::to_string(n_lidar) + ", photometric " +
                     std::to_string(n_photo) + ")";
      break;
    }
    ceres::Solver::Summary summary;
    const double step = solveAndUpdate(&jp, js, st, &summary);
    res->stable = step < 1.0;
    if (debug)
      std::fprintf(stderr,
                   "joint outer %d: %d LiDAR, %d photometric residuals, step %.2f, T_cl t [%.4f "
                   "%.4f %.4f], baseline %.4f, %s\n",
                   res->rounds, n_lidar, n_photo, step, st->T_cl.translation().x(),
                   st->T_cl.translation().y(), st->T_cl.translation().z(),
                   st->T_rl.translation().norm(), summary.BriefReport().c_str());
    if (res->stable) break;
  }
  res->rounds = std::min(res->rounds, js.max_outer);
}

/// The joint estimates into the result and its verdict: converged, or why not. The flags are those
/// of the covariance solves (LiDAR: statistical part and common biases; left-right: with the
/// LiDAR's uncertainty), as in coCalibrate.
void judge(const std::vector<Keyframe*>& window, const JointState& st, const std::string& doubt,
           const Eigen::Isometry3d& T_cam_lidar_init, const Eigen::Isometry3d& T_right_left_init,
           const JointCalibrationSettings& js, CoCalibrationResult* res) {
  const LidarStereoSettings& ls = js.co.lidar;
  const PhotometricSettings& ps = js.co.stereo;
  // The joint LiDAR covariance takes the pair as its covariance solve does (no propagation).
  res->lidar_covariance_given_stereo = res->lidar.covariance;
  res->lidar.T_cam_lidar = st.T_cl;
  res->lidar.stereo_scale =
      st.T_rl.translation().norm() / window.front()->T_right_left_used.translation().norm();
  res->stereo.T_right_left = st.T_rl;
  for (size_t k = 0; k < window.size(); ++k) res->stereo.brightness[k] = {st.ab[k][0], st.ab[k][1]};
  const bool all =
      std::all_of(res->lidar.observable, res->lidar.observable + 6, [](bool b) { return b; }) &&
      std::all_of(res->stereo.observable, res->stereo.observable + 6, [](bool b) { return b; });
  const Vector6d corr_l = poseError(st.T_cl, T_cam_lidar_init);
  const Vector6d corr_s = poseError(st.T_rl, T_right_left_init);
  const bool diverged = corr_l.head<3>().norm() * kDegPerRad > ls.max_correction_rot_deg ||
                        corr_l.tail<3>().norm() > ls.max_correction_trans_m ||
                        corr_s.head<3>().norm() * kDegPerRad > ps.max_correction_rot_deg ||
                        corr_s.tail<3>().norm() > ps.max_correction_trans_m;
  res->lidar.converged = res->stereo.converged = false;
  if (ls.cancelled()) res->message = "cancelled";
  if (!res->message.empty()) {
  } else if (!res->lidar.covariance_known || !res->stereo.covariance_known)
    res->message = "the covariance solves at the joint estimate gave no covariance";
  else if (!doubt.empty())
    res->message = doubt;
  else if (!(res->stereo.consistency_ratio <= ps.max_consistency_ratio))
    res->message = "not photo-consistent at the joint estimate (median key point residual " +
                   std::to_string(res->stereo.consistency_ratio) +
                   " of its value with the right image 4 px off)";
  else if (!res->stable)
    res->message =
        "joint estimate still moving after " + std::to_string(js.max_outer) + " outer iterations";
  else if (diverged)
    res->message = "diverged: the correction from the initial guess is implausibly large";
  else if (!all)
    res->message = "the window does not constrain every axis";
  else
    res->converged = res->lidar.converged = res->stereo.converged = true;
}

}  // namespace

CoCalibrationResult jointCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar_init,
                                   const Eigen::Isometry3d& T_right_left_init,
                                   const JointCalibrationSettings& js) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool debug = std::getenv("TESCALIB_DEBUG") != nullptr;
  const CoCalibrationSettings& s = js.co;
  if (js.max_outer < 1 || js.ceres_iterations < 1)
    return refusal(T_cam_lidar_init, T_right_left_init,
                   "joint calibration settings: max_outer and ceres_iterations must be at least 1");
  const std::string mesh_problem = meshProblem(window);
  if (!mesh_problem.empty()) {
    CoCalibrationResult res = refusal(T_cam_lidar_init, T_right_left_init, mesh_problem);
    res.seconds = secondsSince(t0);
    return res;
  }
  CoCalibrationResult res = initialRounds(window, rig, T_cam_lidar_init, T_right_left_init, s);
  if (s.lidar.cancelled()) {  // during the initial rounds: nothing else runs
    res.lidar.converged = res.stereo.converged = false;
    res.message = "cancelled";
    res.seconds = secondsSince(t0);
    return res;
  }
  const std::string init_message = res.message;
  res.message = initialRoundFailure(window, rig, res, init_message, s);
  if (!res.message.empty()) {
    res.seconds = secondsSince(t0);
    return res;
  }
  JointState st;
  initJointState(window, rig, res, js, &st);
  outerIterations(window, rig, js, debug, &st, &res);
  // The last update can turn the baseline too (checked above only before each iteration).
  if (res.message.empty() && rectifiedBaseline(rig, st.T_rl) <= 0)
    res.message = "the final left-right estimate cannot be rectified side by side";
  // Why the joint estimate is not trusted though the joint problem settled (joint_covariance.h).
  std::string doubt;
  if (res.message.empty())
    doubt =
        covarianceAtJointEstimate(window, rig, st.T_cl, st.T_rl, T_cam_lidar_init, js, debug, &res);
  judge(window, st, doubt, T_cam_lidar_init, T_right_left_init, js, &res);
  res.seconds = secondsSince(t0);
  return res;
}

}  // namespace tescalib
