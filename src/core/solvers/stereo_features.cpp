#include "tescalib/core/solvers/stereo_features.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <ceres/ceres.h>
#include <ceres/sphere_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/video/tracking.hpp>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/solvers/residuals/sampson_epipolar.h"
#include "tescalib/core/uncertainty/ceres_covariance.h"

namespace tescalib {
namespace {

struct Match {
  Eigen::Vector3d x_l, x_r;  ///< normalised image coordinates, z = 1
};

Eigen::Vector3d normalised(const CameraIntrinsics& c, const cv::Point2f& p) {
  return c.ray(p.x, p.y);
}

/// ORB matches of one keyframe that pass the ratio test, refined with LK and kept when tracking
/// back from the right image lands within `max_forward_backward_px` of the left key point.
std::vector<Match> matchKeyframe(const Keyframe& kf, const StereoRig& rig,
                                 const FeatureStereoSettings& s) {
  std::vector<Match> out;
  if (kf.left_gray.empty() || kf.right_gray.empty()) return out;
  cv::Ptr<cv::ORB> orb = cv::ORB::create(s.max_features_per_image);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  orb->detectAndCompute(kf.left_gray, cv::noArray(), kl, dl);
  orb->detectAndCompute(kf.right_gray, cv::noArray(), kr, dr);
  if (kl.size() < 8 || kr.size() < 8) return out;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(dl, dr, knn, 2);
  std::vector<cv::Point2f> pl, pr;
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance >= s.ratio_test * m[1].distance) continue;
    pl.push_back(kl[m[0].queryIdx].pt);
    pr.push_back(kr[m[0].trainIdx].pt);
  }
  if (pl.empty()) return out;
  // ORB's key points sit on its pyramid's pixel grid: LK from the left key point, started at the
  // ORB match, puts the right one to sub-pixel; tracking back checks it.
  const cv::Size win(s.refine_window_px, s.refine_window_px);
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<uchar> ok_f, ok_b;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(kf.left_gray, kf.right_gray, pl, pr, ok_f, err, win, 1, stop,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> back = pl;
  cv::calcOpticalFlowPyrLK(kf.right_gray, kf.left_gray, pr, back, ok_b, err, win, 1, stop,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  const double max_fb2 = s.max_forward_backward_px * s.max_forward_backward_px;
  for (size_t i = 0; i < pl.size(); ++i) {
    if (!ok_f[i] || !ok_b[i]) continue;
    const cv::Point2f d = back[i] - pl[i];
    if (d.x * d.x + d.y * d.y > max_fb2) continue;
    if (pr[i].x < 0 || pr[i].y < 0 || pr[i].x > kf.right_gray.cols - 1 ||
        pr[i].y > kf.right_gray.rows - 1)
      continue;
    out.push_back({normalised(rig.left, pl[i]), normalised(rig.right, pr[i])});
  }
  return out;
}

/// The refinement's residual (Sampson distance, px) of a match at R and the unit direction t.
double sampsonPx(const Match& m, const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double f) {
  const double phi[3] = {0, 0, 0};
  double r = 0;
  SampsonEpipolarResidual(m.x_l, m.x_r, R, f)(phi, t.data(), &r);
  return r;
}

/// Why the inputs give no estimate ("" when they can): intrinsics, the guess' baseline length,
/// the settings' ranges and the keyframes' images.
std::string inputProblem(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                         double length, const FeatureStereoSettings& s) {
  if (!rig.left.valid() || !rig.right.valid()) return "invalid camera intrinsics";
  if (!(length > 0) || !std::isfinite(length)) return "the guess has no baseline length";
  if (s.max_features_per_image < 8 || s.refine_window_px < 3 || !(s.ratio_test > 0) ||
      !(s.ratio_test <= 1) || !(s.max_forward_backward_px > 0) || !(s.ransac_threshold_px > 0) ||
      !(s.huber_px > 0) || s.min_inliers < 8)
    return "settings out of range (max_features_per_image >= 8, refine_window_px >= 3, ratio_test "
           "in (0, 1], thresholds > 0, min_inliers >= 8)";
  for (const Keyframe* kf : window) {
    if (kf->left_gray.empty() && kf->right_gray.empty()) continue;  // no images: no matches
    if (kf->left_gray.type() != CV_8UC1 || kf->right_gray.type() != CV_8UC1 ||
        kf->left_gray.cols != rig.left.width || kf->left_gray.rows != rig.left.height ||
        kf->right_gray.cols != rig.right.width || kf->right_gray.rows != rig.right.height)
      return "a keyframe's grey images are not 8-bit or not of the rig's size";
  }
  return "";
}

/// The matches of every keyframe of the window, in window order (matchKeyframe in parallel).
std::vector<Match> matchWindow(const std::vector<const Keyframe*>& window, const StereoRig& rig,
                               const FeatureStereoSettings& s) {
  std::vector<std::vector<Match>> per_kf(window.size());
  parallelFor(static_cast<int>(window.size()), resolveThreads(s.threads),
              [&](int i) { per_kf[i] = matchKeyframe(*window[i], rig, s); });
  std::vector<Match> all;
  for (const auto& v : per_kf) all.insert(all.end(), v.begin(), v.end());
  return all;
}

Eigen::Matrix3d toEigen(const cv::Mat& m) {
  Eigen::Matrix3d e;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e(r, c) = m.at<double>(r, c);
  return e;
}

/// The epipolar geometry of the pair: the right camera's rotation and the unit baseline direction.
struct Epipolar {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

/// The essential matrix by RANSAC over the matches (normalised coordinates, focal length `f` for
/// the pixel threshold) and of its four poses the one nearest `guess`; "" or why there is none.
std::string essentialPose(const std::vector<Match>& all, double f, const Eigen::Isometry3d& guess,
                          const FeatureStereoSettings& s, Epipolar* pose) {
  std::vector<cv::Point2d> pl(all.size()), pr(all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    pl[i] = {all[i].x_l.x(), all[i].x_l.y()};
    pr[i] = {all[i].x_r.x(), all[i].x_r.y()};
  }
  cv::Mat mask, E;
  try {
    E = cv::findEssentialMat(pl, pr, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999,
                             s.ransac_threshold_px / f, mask);
  } catch (const cv::Exception& e) {
    return std::string("essential matrix: ") + e.what();
  }
  // findEssentialMat stacks several 3x3 solutions when the 5-point solver finds more than one;
  // the first is RANSAC's best.
  if (E.rows < 3 || E.cols != 3) return "no essential matrix fits the matches";
  E = E.rowRange(0, 3).clone();
  // Of E's four poses, the rotation nearer the guess and the baseline on the guess' side: with
  // most matches far away, cheirality alone can pick the mirrored baseline (real KITTI 2011_10_03
  // did, its rotation 0.13 deg off).
  cv::Mat R1, R2, tcv;
  cv::decomposeEssentialMat(E, R1, R2, tcv);
  const Eigen::Matrix3d Rg = guess.linear();
  const Eigen::Matrix3d Ra = toEigen(R1), Rb = toEigen(R2);
  pose->R = logSO3(Ra * Rg.transpose()).norm() <= logSO3(Rb * Rg.transpose()).norm() ? Ra : Rb;
  pose->t = Eigen::Vector3d(tcv.at<double>(0), tcv.at<double>(1), tcv.at<double>(2));
  if (pose->t.dot(guess.translation()) < 0) pose->t = -pose->t;
  return "";
}

/// The covariance of the Sampson refinement's rotation correction and baseline direction (its
/// tangent space), for unit residual variance.
struct EpipolarCovariance {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Zero();
  Eigen::Matrix2d direction = Eigen::Matrix2d::Zero();
};

/// Ceres' covariance of the solved refinement `problem` at `phi` (rotation) and `tv` (unit
/// direction); a huge one when it cannot be computed.
EpipolarCovariance epipolarCovariance(ceres::Problem* problem, const double* phi, const double* tv,
                                      int threads) {
  ceres::Covariance::Options co;
  co.num_threads = threads;
  std::vector<RowMajorMatrixXd> c;
  EpipolarCovariance out;
  if (blockCovariances(problem, {phi, tv}, co, &c)) {
    // Ceres' row-major blocks read column-major (their transposes: symmetric up to rounding).
    out.rotation = c[0].transpose();
    out.direction = c[1].transpose();
  } else {
    out.rotation.setConstant(1e6), out.direction.setConstant(1e6);
  }
  return out;
}

/// Refines `pose` on the matches within the RANSAC threshold by the Sampson distance (Huber),
/// twice, the inliers re-selected with the refined pose; returns the last inliers (fewer than
/// min_inliers: `pose` and `cov` as the last full pass left them) and sets `cov` from the second.
std::vector<int> refineSampson(const std::vector<Match>& all, double f,
                               const FeatureStereoSettings& s, Epipolar* pose,
                               EpipolarCovariance* cov) {
  Eigen::Matrix3d& R = pose->R;
  Eigen::Vector3d& t = pose->t;
  std::vector<int> inl;
  for (int pass = 0; pass < 2; ++pass) {
    inl.clear();
    for (size_t i = 0; i < all.size(); ++i)
      if (std::fabs(sampsonPx(all[i], R, t, f)) < s.ransac_threshold_px) inl.push_back(i);
    if (static_cast<int>(inl.size()) < s.min_inliers) break;
    double phi[3] = {0, 0, 0};
    double tv[3] = {t.x(), t.y(), t.z()};
    ceres::Problem problem;
    for (int i : inl)
      problem.AddResidualBlock(SampsonEpipolarResidual::Create(all[i].x_l, all[i].x_r, R, f),
                               new ceres::HuberLoss(s.huber_px), phi, tv);
    problem.SetManifold(tv, new ceres::SphereManifold<3>());
    ceres::Solver::Options opt;
    opt.max_num_iterations = 50;
    opt.num_threads = resolveThreads(s.threads);
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    R = expSO3(Eigen::Vector3d(phi[0], phi[1], phi[2])) * R;
    t = Eigen::Vector3d(tv[0], tv[1], tv[2]).normalized();
    if (pass == 1) *cov = epipolarCovariance(&problem, phi, tv, opt.num_threads);
  }
  return inl;
}

/// The inliers' RMS Sampson residual and the largest 1-sigma of the rotation and of the baseline
/// direction (deg), Ceres' covariance scaled by the residuals' variance.
void epipolarUncertainty(const std::vector<Match>& all, const std::vector<int>& inl,
                         const Epipolar& pose, double f, const EpipolarCovariance& cov,
                         FeatureStereoResult* res) {
  double ss = 0;
  for (int i : inl) ss += std::pow(sampsonPx(all[i], pose.R, pose.t, f), 2);
  res->rms_px = std::sqrt(ss / inl.size());
  // Ceres' covariance assumes unit residual variance: scale by the residuals' own.
  const double var = res->rms_px * res->rms_px;
  res->sigma_rot_deg = largestSigma<3>(cov.rotation * var) * kDegPerRad;
  res->sigma_direction_deg = largestSigma<2>(cov.direction * var) * kDegPerRad;
}

}  // namespace

FeatureStereoResult estimateStereoFromFeatures(const std::vector<const Keyframe*>& window,
                                               const StereoRig& rig,
                                               const Eigen::Isometry3d& T_right_left_guess,
                                               const FeatureStereoSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  FeatureStereoResult res;
  res.T_right_left = T_right_left_guess;
  const double length = T_right_left_guess.translation().norm();
  auto done = [&](const std::string& why) {
    res.message = why;
    res.seconds = secondsSince(t0);
    return res;
  };
  const std::string input_problem = inputProblem(window, rig, length, s);
  if (!input_problem.empty()) return done(input_problem);
  std::vector<Match> all;
  try {
    all = matchWindow(window, rig, s);
  } catch (const cv::Exception& e) {
    return done(std::string("feature matching failed: ") + e.what());
  }
  res.matches = static_cast<int>(all.size());
  if (res.matches < s.min_inliers) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%d left-right feature matches in the window (%d needed)",
                  res.matches, s.min_inliers);
    return done(buf);
  }
  const double f = 0.5 * (rig.left.fx + rig.right.fx);
  Epipolar pose;
  const std::string no_pose = essentialPose(all, f, T_right_left_guess, s, &pose);
  if (!no_pose.empty()) return done(no_pose);
  EpipolarCovariance cov;
  const std::vector<int> inl = refineSampson(all, f, s, &pose, &cov);
  res.inliers = static_cast<int>(inl.size());
  if (res.inliers < s.min_inliers) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "%d of %d left-right matches fit one epipolar geometry (%d needed)", res.inliers,
                  res.matches, s.min_inliers);
    return done(buf);
  }
  epipolarUncertainty(all, inl, pose, f, cov, &res);
  res.T_right_left.linear() = pose.R;
  res.T_right_left.translation() = pose.t * length;
  if (res.sigma_rot_deg > s.max_sigma_rot_deg ||
      res.sigma_direction_deg > s.max_sigma_direction_deg) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the matches do not constrain the pair: sigma %.3f deg (rotation), %.2f deg "
                  "(baseline direction)",
                  res.sigma_rot_deg, res.sigma_direction_deg);
    return done(buf);
  }
  res.ok = true;
  return done("");
}

}  // namespace tescalib
