#include "tescalib/core/solvers/joint_calibration.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/image_sampling.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/lidar/mesh_depth.h"
#include "tescalib/core/solvers/residuals/photometric_residual.h"
#include "tescalib/core/solvers/residuals/point_plane_distance.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {
namespace {

using Clock = std::chrono::steady_clock;

/// LiDAR fine residual, paper eq. point_point_normal_obj, r = n^T (T p_l - F(d')) / sigma, with
/// the stereo point F linearised in T_right_left (see the header): its baseline is |t_rl| (exact:
/// F scales with it), and its disparity d' = d + f dx corrects to first order for the rotation
/// phi between the right camera of the estimate and the one the cloud was rectified with:
/// a right camera rotated by phi sees the point at x_r + dx,
///   dx = phi_y (1 + x_r^2) - phi_z y - phi_x x_r y   (x_r, y: normalised right coordinates),
/// so SGBM measured d - f dx. (The rectification rotations themselves are tenths of a degree:
/// phi is taken in the rectified right frame; phi's lever on the baseline direction is left to
/// re-rectification.)
struct JointLidarResidual {
  Eigen::Vector3d q, m, t;  ///< R_cl p_l, R_cl n_l, t_cl (reference)
  double u, v, d;           ///< rectified pixel and measured disparity
  double fx, fy, cx, cy;
  Eigen::Matrix3d R_rect;
  Eigen::Vector3d t_rl;  ///< reference left-right translation
  Eigen::Vector3d phi0;  ///< rotation of the reference right camera from the clouds' one
  double inv_sigma;

  template <typename T>
  bool operator()(const T* const d_cl, const T* const d_rl, T* residual) const {
    T b2 = T(0);
    for (int i = 0; i < 3; ++i) b2 += (T(t_rl[i]) + d_rl[3 + i]) * (T(t_rl[i]) + d_rl[3 + i]);
    const T phi[3] = {d_rl[0] + T(phi0.x()), d_rl[1] + T(phi0.y()), d_rl[2] + T(phi0.z())};
    const double xr = (u - d - cx) / fx, y = (v - cy) / fy;
    const T dx = phi[1] * (1.0 + xr * xr) - phi[2] * y - phi[0] * xr * y;
    const T disp = T(d) + T(fx) * dx;
    if (disp < T(0.5)) return false;
    const T Z = T(fx) * ceres::sqrt(b2) / disp;
    const T pr[3] = {T((u - cx) / fx) * Z, T((v - cy) / fy) * Z, Z};
    Eigen::Matrix<T, 3, 1> p;
    for (int i = 0; i < 3; ++i)
      p[i] = T(R_rect(0, i)) * pr[0] + T(R_rect(1, i)) * pr[1] + T(R_rect(2, i)) * pr[2];
    const T qq[3] = {T(q.x()), T(q.y()), T(q.z())};
    const T mm[3] = {T(m.x()), T(m.y()), T(m.z())};
    T c[3], n[3];
    ceres::AngleAxisRotatePoint(d_cl, qq, c);
    ceres::AngleAxisRotatePoint(d_cl, mm, n);
    T dist = T(0);
    for (int i = 0; i < 3; ++i) dist += n[i] * (c[i] + T(t[i]) + d_cl[3 + i] - p[i]);
    residual[0] = dist * T(inv_sigma);
    return true;
  }
};

/// Photometric residual (as PhotometricResidual) whose pattern points are the intersections of
/// the left rays with the key point's LiDAR face under T_cam_lidar = perturb(T_cl_ref, d_cl).
struct JointPhotometricResidual {
  const ImageInterpolator* right;
  std::array<Eigen::Vector3d, kPatternSize> rays;  ///< left rays (z = 1)
  Eigen::Vector3d q_f, m_f, t_cl;                  ///< R_cl p_face, R_cl n_face, t_cl (reference)
  Eigen::Matrix3d R_rl;
  Eigen::Vector3d t_rl;
  std::array<double, kPatternSize> left;
  double sqrt_w, fx, fy, cx, cy;

  template <typename T>
  bool operator()(const T* const d_rl, const T* const ab, const T* const d_cl, T* residual) const {
    const T qf[3] = {T(q_f.x()), T(q_f.y()), T(q_f.z())};
    const T mf[3] = {T(m_f.x()), T(m_f.y()), T(m_f.z())};
    T m[3], c[3];
    ceres::AngleAxisRotatePoint(d_cl, mf, m);
    ceres::AngleAxisRotatePoint(d_cl, qf, c);
    T mc = T(0);
    for (int i = 0; i < 3; ++i) mc += m[i] * (c[i] + T(t_cl[i]) + d_cl[3 + i]);
    const T gain = ceres::exp(ab[0]);
    for (int k = 0; k < kPatternSize; ++k) {
      const Eigen::Vector3d& r = rays[k];
      const T mr = m[0] * r.x() + m[1] * r.y() + m[2] * r.z();
      if (ceres::abs(mr) < T(1e-9)) return false;
      const T lambda = mc / mr;
      if (lambda < T(0.5)) return false;
      T x[3], y[3];
      for (int i = 0; i < 3; ++i)
        x[i] = lambda * (R_rl(i, 0) * r.x() + R_rl(i, 1) * r.y() + R_rl(i, 2) * r.z());
      ceres::AngleAxisRotatePoint(d_rl, x, y);
      for (int i = 0; i < 3; ++i) y[i] += T(t_rl[i]) + d_rl[3 + i];
      if (y[2] < T(0.1)) return false;
      const T u = T(fx) * y[0] / y[2] + T(cx);
      const T v = T(fy) * y[1] / y[2] + T(cy);
      T value;
      right->Evaluate(v, u, &value);
      residual[k] = T(sqrt_w) * (value - ab[1] - gain * T(left[k]));
    }
    return true;
  }
};

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

}  // namespace

CoCalibrationResult jointCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                   const Eigen::Isometry3d& T_cam_lidar_init,
                                   const Eigen::Isometry3d& T_right_left_init,
                                   const JointCalibrationSettings& js) {
  const auto t0 = Clock::now();
  const bool debug = std::getenv("TESCALIB_DEBUG") != nullptr;
  const CoCalibrationSettings& s = js.co;
  const LidarStereoSettings& ls = s.lidar;
  const PhotometricSettings& ps = s.stereo;
  if (js.max_outer < 1 || js.ceres_iterations < 1) {
    CoCalibrationResult res;
    res.lidar.T_cam_lidar = T_cam_lidar_init;
    res.stereo.T_right_left = T_right_left_init;
    res.message = "joint calibration settings: max_outer and ceres_iterations must be at least 1";
    return res;
  }
  for (size_t k = 0; k < window.size(); ++k) {
    const LidarMesh& m = window[k]->mesh;
    if (m.sample.size() == m.faces.size()) continue;
    CoCalibrationResult res;
    res.lidar.T_cam_lidar = T_cam_lidar_init;
    res.stereo.T_right_left = T_right_left_init;
    res.message =
        "joint calibration needs every face's normal fitted (LidarMeshSettings::"
        "sampled_faces = 0): keyframe " +
        std::to_string(k) + "'s mesh has " + std::to_string(m.sample.size()) + " of " +
        std::to_string(m.faces.size());
    res.seconds = secondsSince(t0);
    return res;
  }
  // ------------------------------------------------------------ initialisation
  // Alternation rounds until one included a photometric solve (its key points, brightness and
  // cost set up the problem below): with stereo_from_features, round 1 takes the pair from
  // feature matches and solves LiDAR-stereo with the wide-basin search, round 2 is photometric.
  CoCalibrationSettings init = s;
  init.max_rounds = s.stereo_from_features ? 2 : 1;
  init.extrapolate = false;
  // Nothing of what the alternation does at its end or between its rounds for its own result:
  // no yaw handover (in round 2 it restarts the LiDAR at the initial guess, and the rounds end
  // there: review, session 35), no split-window check, no sensitivity to the pair, no second
  // opinion (the joint estimate gets its covariances from the solves below).
  init.yaw_handover_deg = -1;
  init.lidar.check_window_halves = false;
  init.propagate_stereo_into_lidar = false;
  init.confirm_beyond_deg = init.confirm_beyond_m = -1;
  CoCalibrationResult res = coCalibrate(window, rig, T_cam_lidar_init, T_right_left_init, init);
  res.stable = res.converged = false;
  res.rounds = 0;
  // The alternation's own bookkeeping does not describe the joint result (`features`,
  // `rectifications` and `rematches` do: they count the whole solve).
  res.extrapolations = res.rejected = res.yaw_handovers = 0;
  res.lidar_first = false;
  res.lidar_stereo_sensitivity.setZero();
  res.coupling = 0;
  if (s.lidar.cancelled()) {  // during the initial rounds: nothing else runs
    res.lidar.converged = res.stereo.converged = false;
    res.message = "cancelled";
    res.seconds = secondsSince(t0);
    return res;
  }
  const std::string init_message = res.message;
  res.message.clear();
  // A pair the clouds cannot be rectified with: the round said why (coCalibrate's message).
  const bool unusable_pair =
      !window.empty() && rectifiedBaseline(rig, res.stereo.T_right_left) <= 0;
  if (window.empty() || res.stereo.keypoints < ps.min_keypoints ||
      res.stereo.brightness.size() != window.size() || res.lidar.fine_inliers < ls.min_inliers ||
      unusable_pair) {
    res.message = "initial round failed: " +
                  (window.empty() ? std::string("empty window")
                   : unusable_pair || (res.stereo.message.empty() && res.lidar.message.empty())
                       ? init_message
                       : res.stereo.message + " / " + res.lidar.message);
    res.seconds = secondsSince(t0);
    return res;
  }
  Eigen::Isometry3d T_cl = res.lidar.T_cam_lidar, T_rl = res.stereo.T_right_left;
  const double sigma_ph = js.photometric_sigma > 0
                              ? js.photometric_sigma
                              : std::sqrt(std::max(1.0, res.stereo.final_cost));

  // Key points (chosen once, with the initial round's LiDAR extrinsic) and images.
  std::vector<const Keyframe*> cwin(window.begin(), window.end());
  std::vector<std::vector<KeyPoint>> kps(window.size());
  std::vector<Images> img(window.size());
  for (size_t k = 0; k < window.size(); ++k) {
    kps[k] = selectKeyPoints(*window[k], renderMeshDepth(window[k]->mesh, T_cl, rig.left), ps);
    window[k]->left_gray.convertTo(img[k].left, CV_64F);
    cv::Mat r;
    window[k]->right_gray.convertTo(r, CV_64F);
    img[k].right_data.assign(reinterpret_cast<const double*>(r.data),
                             reinterpret_cast<const double*>(r.data) + r.total());
    img[k].grid =
        std::make_unique<ceres::Grid2D<double, 1>>(img[k].right_data.data(), 0, r.rows, 0, r.cols);
    img[k].interp = std::make_unique<ImageInterpolator>(*img[k].grid);
  }
  std::vector<std::array<double, 2>> ab(window.size());
  for (size_t k = 0; k < window.size(); ++k)
    ab[k] = {res.stereo.brightness[k].x(), res.stereo.brightness[k].y()};
  const double c2 = ps.gradient_weight_c * ps.gradient_weight_c;

  // ------------------------------------------------------------ outer iterations
  for (res.rounds = 1; res.rounds <= js.max_outer; ++res.rounds) {
    if (s.lidar.cancelled()) {  // LidarStereoSettings::cancel, as coCalibrate honours it
      res.message = "cancelled";
      break;
    }
    // Re-rectify when the left-right rotation or direction moved enough to matter.
    if (rectifiedBaseline(rig, T_rl) <= 0) {
      res.message = "the left-right estimate of outer iteration " + std::to_string(res.rounds) +
                    " cannot be rectified side by side (its baseline turned away from -x)";
      break;
    }
    RectifyTolerances tol = rectifyTolerances(s);
    tol.direction_deg = tol.yaw_deg = -1.0;  // the joint problem has no yaw nuisance
    res.rectifications += rectifyWindow(window, rig, T_rl, s.stereo_cloud, tol,
                                        &res.seconds_stereo_cloud, &res.rematches) > 0;

    double d_cl[6] = {0, 0, 0, 0, 0, 0}, d_rl[6] = {0, 0, 0, 0, 0, 0};
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    ceres::HuberLoss lidar_loss(ls.fine_huber), photo_loss(ps.huber / sigma_ph);

    // LiDAR-stereo fine residuals: projective association at the current estimate.
    int n_lidar = 0;
    const Eigen::Matrix3d R = T_cl.linear();
    for (size_t k = 0; k < window.size(); ++k) {
      const StereoCloud& st = window[k]->stereo;
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
        const Eigen::Vector3d pr = st.R_rect_left * c;
        if (pr.z() < 1.0 || pr.z() > ls.max_depth) continue;
        const double u = st.fx * pr.x() / pr.z() + st.cx, v = st.fy * pr.y() / pr.z() + st.cy;
        double d;
        if (!st.disparityAt(u, v, &d)) continue;
        const Eigen::Vector3d p_s = st.pointAt(u, v, d);
        const Eigen::Vector3d m = R * f.normal.cast<double>();
        const double inv_sigma = pointPlaneInvSigma(m, c.normalized(), f.range, p_s, d, scale,
                                                    s.stereo_cloud.disparity_sigma, ls);
        if (std::fabs(m.dot(c - scale * p_s)) * inv_sigma > ls.fine_gate_sigma) continue;
        auto* lr = new JointLidarResidual;
        lr->q = q, lr->m = m, lr->t = T_cl.translation();
        lr->u = u, lr->v = v, lr->d = d;
        lr->fx = st.fx, lr->fy = st.fy, lr->cx = st.cx, lr->cy = st.cy;
        lr->R_rect = st.R_rect_left;
        lr->t_rl = T_rl.translation();
        lr->phi0 = phi0;
        lr->inv_sigma = inv_sigma;
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<JointLidarResidual, 1, 6, 6>(lr),
                                 &lidar_loss, d_cl, d_rl);
        ++n_lidar;
      }
    }
    // Photometric residuals at full resolution, visible in the right image.
    int n_photo = 0;
    for (size_t k = 0; k < window.size(); ++k) {
      const MeshDepth right_md = renderMeshDepth(window[k]->mesh, T_rl * T_cl, rig.right);
      for (const KeyPoint& kp : kps[k]) {
        const MeshFace& f = window[k]->mesh.faces[kp.face];
        Eigen::Vector3d X;
        if (!intersectFace(f, T_cl, rig.left, kp.u, kp.v, &X)) continue;
        if (visibility(T_rl * X, rig.right, right_md, ps.occlusion_tolerance) !=
            Visibility::kVisible)
          continue;
        auto* r = new JointPhotometricResidual;
        r->right = img[k].interp.get();
        bool ok = true;
        for (int p = 0; p < kPatternSize && ok; ++p) {
          const double pu = kp.u + kPattern[p][0], pv = kp.v + kPattern[p][1];
          r->rays[p] = {(pu - rig.left.cx) / rig.left.fx, (pv - rig.left.cy) / rig.left.fy, 1.0};
          r->left[p] = bilinear(img[k].left, pu, pv);
          ok = std::isfinite(r->left[p]);
        }
        if (!ok) {
          delete r;
          continue;
        }
        r->q_f = R * f.centroid.cast<double>();
        r->m_f = R * f.normal.cast<double>();
        r->t_cl = T_cl.translation();
        r->R_rl = T_rl.linear();
        r->t_rl = T_rl.translation();
        // The 8 pattern pixels of a key point share its depth and most of its information: they
        // count as one observation against the LiDAR residuals (each is one face).
        r->sqrt_w = std::sqrt(c2 / (c2 + kp.grad2) / kPatternSize) / sigma_ph;
        r->fx = rig.right.fx, r->fy = rig.right.fy, r->cx = rig.right.cx, r->cy = rig.right.cy;
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<JointPhotometricResidual, kPatternSize, 6, 2, 6>(r),
            &photo_loss, d_rl, ab[k].data(), d_cl);
        ++n_photo;
      }
    }
    res.lidar.fine_inliers = n_lidar;
    res.stereo.inliers = n_photo;
    if (n_lidar < ls.min_inliers || n_photo < ps.min_keypoints) {
      res.message = "too few residuals (LiDAR " + std::to_string(n_lidar) + ", photometric " +
                    std::to_string(n_photo) + ")";
      break;
    }
    ceres::Solver::Options opt;
    opt.linear_solver_type = ceres::DENSE_SCHUR;
    opt.max_num_iterations = js.ceres_iterations;
    opt.num_threads = ls.threads;
    opt.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    Vector6d dc, dr;
    for (int i = 0; i < 6; ++i) dc[i] = d_cl[i], dr[i] = d_rl[i];
    const Eigen::Isometry3d T_cl_new = perturb(T_cl, dc), T_rl_new = perturb(T_rl, dr);
    const double step =
        std::max(normalisedStep(T_cl_new, T_cl, s), normalisedStep(T_rl_new, T_rl, s));
    T_cl = T_cl_new, T_rl = T_rl_new;
    res.stable = step < 1.0;
    if (debug)
      std::fprintf(stderr,
                   "joint outer %d: %d LiDAR, %d photometric residuals, step %.2f, T_cl t [%.4f "
                   "%.4f %.4f], baseline %.4f, %s\n",
                   res.rounds, n_lidar, n_photo, step, T_cl.translation().x(),
                   T_cl.translation().y(), T_cl.translation().z(), T_rl.translation().norm(),
                   summary.BriefReport().c_str());
    if (res.stable) break;
  }
  res.rounds = std::min(res.rounds, js.max_outer);
  // The last update can turn the baseline too (checked above only before each iteration).
  if (res.message.empty() && rectifiedBaseline(rig, T_rl) <= 0)
    res.message = "the final left-right estimate cannot be rectified side by side";
  // Why the joint estimate is not trusted though the joint problem settled: a covariance solve
  // at it that did not converge itself (a LiDAR-stereo solve that did not settle there has no
  // split-window check either, and its covariance does not describe the joint estimate; session
  // 35: a real KITTI 2011_10_03 start was declared converged 4.75 cm from KITTI's calibration at
  // sigma 0.78 cm, that solve had moved 15 mm and not settled), or the second opinion's doubt.
  std::string doubt;
  if (res.message.empty()) {
    // Covariances: the joint problem's own marginals take every residual as independent and were
    // over-confident (mean NEES 33 on 7 generated windows, session 8). Instead the alternation's
    // NEES-calibrated covariances are evaluated at the joint estimate: the clouds brought to it,
    // one warm left-right solve and one LiDAR-stereo fine solve (scale and yaw free, split-window
    // check) started there. Their covariances are taken, combined as coCalibrate combines them;
    // their estimates are not (the estimate stays the joint one).
    rectifyWindow(window, rig, T_rl, s.stereo_cloud, rectifyTolerances(s),
                  &res.seconds_stereo_cloud, &res.rematches);
    const auto t_ph = Clock::now();
    PhotometricResult ph = solvePhotometric(cwin, rig, T_cl, T_rl, coPhotometricSettings(s, true));
    res.seconds_photometric += secondsSince(t_ph);
    LidarStereoSettings lw = coLidarStereoSettings(s);
    lw.run_coarse = false;
    const auto t_l = Clock::now();
    LidarStereoResult lr = solveLidarStereo(cwin, T_cl, lw);
    res.seconds_lidar += secondsSince(t_l);
    if (debug) {
      const Vector6d el = poseError(lr.T_cam_lidar, T_cl), es = poseError(ph.T_right_left, T_rl);
      std::fprintf(stderr,
                   "joint covariance solves moved the LiDAR by %.4f deg / %.2f mm and the right "
                   "camera by %.4f deg / %.2f mm (%s / %s)\n",
                   el.head<3>().norm() * kDegPerRad, el.tail<3>().norm() * 1e3,
                   es.head<3>().norm() * kDegPerRad, es.tail<3>().norm() * 1e3,
                   lr.converged ? "converged" : lr.message.c_str(),
                   ph.converged ? "converged" : ph.message.c_str());
    }
    addAxisVariances(&lr.covariance, js.co_model_sigma_lidar_rot_deg,
                     js.co_model_sigma_lidar_trans_m);
    ph.T_right_left = T_rl;
    CoCalibrationSettings s_cov = s;
    s_cov.model_sigma_stereo_rot_deg = js.co_model_sigma_stereo_rot_deg;
    s_cov.model_sigma_stereo_trans_m = js.co_model_sigma_stereo_trans_m;
    coStereoCovariance(lr, s_cov, &ph);
    addAxisVariances(&lr.covariance, js.model_sigma_lidar_rot_deg, js.model_sigma_lidar_trans_m);
    addAxisVariances(&ph.covariance, js.model_sigma_stereo_rot_deg, js.model_sigma_stereo_trans_m);
    if (!lr.converged)
      doubt = "the LiDAR-stereo solve at the joint estimate did not converge: " + lr.message;
    else if (!ph.converged)
      doubt = "the left-right solve at the joint estimate did not converge: " + ph.message;
    else {
      // An estimate far from the initial guess gets co-calibration's second opinion (a
      // LiDAR-stereo solve from the guess with the final clouds; CoCalibrationSettings::
      // confirm_*), which the initial rounds leave out.
      LidarStereoResult at_joint = lr;
      at_joint.T_cam_lidar = T_cl;
      double seconds = 0;
      doubt = secondOpinion(cwin, T_cam_lidar_init, at_joint, lw, s, &seconds);
      res.seconds_lidar += seconds;
    }
    // The LiDAR result is that solve's (covariances, information, flags, split-window check) with
    // the joint estimate and the joint problem's association count.
    const int joint_inliers = res.lidar.fine_inliers;
    res.lidar = lr;
    res.lidar.fine_inliers = joint_inliers;
    res.stereo.covariance = ph.covariance;
    res.stereo.covariance_known = ph.covariance_known;
    res.stereo.lidar_sensitivity = ph.lidar_sensitivity;
    std::copy(ph.observable, ph.observable + 6, res.stereo.observable);
    // Its photo-consistency and directions too (they were the first round's), so that flags,
    // message and ratio describe one solve.
    res.stereo.consistency_ratio = ph.consistency_ratio;
    res.stereo.weak_directions = ph.weak_directions;
    res.stereo.message = ph.message;
    res.stereo.final_cost = ph.final_cost;  // not the first round's, at another T_right_left
    res.stereo.iterations = ph.iterations;
  }
  // The joint LiDAR covariance takes the pair as its covariance solve does (no propagation).
  res.lidar_covariance_given_stereo = res.lidar.covariance;
  res.lidar.T_cam_lidar = T_cl;
  res.lidar.stereo_scale =
      T_rl.translation().norm() / window.front()->T_right_left_used.translation().norm();
  res.stereo.T_right_left = T_rl;
  for (size_t k = 0; k < window.size(); ++k) res.stereo.brightness[k] = {ab[k][0], ab[k][1]};
  // The flags are those of the covariance solves (LiDAR: statistical part and common biases;
  // left-right: with the LiDAR's uncertainty), as in coCalibrate.
  const bool all =
      std::all_of(res.lidar.observable, res.lidar.observable + 6, [](bool b) { return b; }) &&
      std::all_of(res.stereo.observable, res.stereo.observable + 6, [](bool b) { return b; });
  const Vector6d corr_l = poseError(T_cl, T_cam_lidar_init);
  const Vector6d corr_s = poseError(T_rl, T_right_left_init);
  const bool diverged = corr_l.head<3>().norm() * kDegPerRad > ls.max_correction_rot_deg ||
                        corr_l.tail<3>().norm() > ls.max_correction_trans_m ||
                        corr_s.head<3>().norm() * kDegPerRad > ps.max_correction_rot_deg ||
                        corr_s.tail<3>().norm() > ps.max_correction_trans_m;
  res.lidar.converged = res.stereo.converged = false;
  if (s.lidar.cancelled()) res.message = "cancelled";
  if (!res.message.empty()) {
  } else if (!res.lidar.covariance_known || !res.stereo.covariance_known)
    res.message = "the covariance solves at the joint estimate gave no covariance";
  else if (!doubt.empty())
    res.message = doubt;
  else if (!(res.stereo.consistency_ratio <= ps.max_consistency_ratio))
    res.message = "not photo-consistent at the joint estimate (median key point residual " +
                  std::to_string(res.stereo.consistency_ratio) +
                  " of its value with the right image 4 px off)";
  else if (!res.stable)
    res.message =
        "joint estimate still moving after " + std::to_string(js.max_outer) + " outer iterations";
  else if (diverged)
    res.message = "diverged: the correction from the initial guess is implausibly large";
  else if (!all)
    res.message = "the window does not constrain every axis";
  else
    res.converged = res.lidar.converged = res.stereo.converged = true;
  res.seconds = secondsSince(t0);
  return res;
}

}  // namespace tescalib
