#include "tescalib/core/solvers/co_calibration.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <limits>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/timing.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

namespace {

using Clock = std::chrono::steady_clock;

using Vector12d = Eigen::Matrix<double, 12, 1>;

/// Both extrinsics as one 12-vector relative to a reference pair, each component divided by its
/// stability tolerance (so that 1 is "just stable").
Vector12d normalisedDifference(const Eigen::Isometry3d& cl, const Eigen::Isometry3d& rl,
                               const Eigen::Isometry3d& cl_ref, const Eigen::Isometry3d& rl_ref,
                               const CoCalibrationSettings& s) {
  Vector12d x;
  x << poseError(cl, cl_ref), poseError(rl, rl_ref);
  for (int i = 0; i < 12; ++i)
    x[i] /= (i % 6 < 3) ? s.stable_rot_deg / kDegPerRad : s.stable_trans_m;
  return x;
}

/// Largest component of the normalised difference in max-norm per (extrinsic, rot/trans) block.
double stepSize(const Vector12d& x) {
  if (!x.allFinite()) return std::numeric_limits<double>::infinity();  // never "stable"
  double m = 0;
  for (int b = 0; b < 4; ++b) m = std::max(m, x.segment<3>(3 * b).norm());
  return m;
}

Eigen::Isometry3d applyNormalised(const Eigen::Isometry3d& T, const Vector6d& x_norm,
                                  const CoCalibrationSettings& s) {
  Vector6d d = x_norm;
  d.head<3>() *= s.stable_rot_deg / kDegPerRad;
  d.tail<3>() *= s.stable_trans_m;
  return perturb(T, d);
}

}  // namespace

RectifyTolerances rectifyTolerances(const CoCalibrationSettings& s) {
  RectifyTolerances t;
  t.rot_deg = s.rerectify_deg;
  t.direction_deg = s.rerectify_direction_deg;
  t.yaw_deg = s.lidar_estimates_stereo_yaw ? s.rerectify_yaw_deg : -1.0;
  t.rematch_rot_deg = s.rematch_deg;
  t.rematch_direction_deg = s.rematch_direction_deg;
  return t;
}

LidarStereoSettings coLidarStereoSettings(const CoCalibrationSettings& s) {
  LidarStereoSettings ls = s.lidar;
  ls.disparity_sigma = s.stereo_cloud.disparity_sigma;
  ls.estimate_stereo_scale = true;
  // The clouds' rectification yaw is a nuisance here: a yaw error of the right camera shifts
  // every disparity, which the LiDAR would otherwise absorb along the optical axis; the yaw
  // itself stays the photometric solver's (with a good LiDAR it is far more precise).
  ls.estimate_stereo_yaw = s.lidar_estimates_stereo_yaw;
  return ls;
}

PhotometricSettings coPhotometricSettings(const CoCalibrationSettings& s, bool warm) {
  PhotometricSettings ps = s.stereo;
  ps.fix_baseline_length = s.photometric_fixed_length;
  if (warm) {
    ps.pyramid_levels = std::min(ps.pyramid_levels, s.warm_pyramid_levels);
    ps.iterations_per_level = s.warm_iterations;
  }
  return ps;
}

std::string secondOpinion(const std::vector<const Keyframe*>& window,
                          const Eigen::Isometry3d& T_cam_lidar_init, const LidarStereoResult& lidar,
                          const LidarStereoSettings& settings, const CoCalibrationSettings& s,
                          double* seconds) {
  if (seconds) *seconds = 0;
  if (!lidar.converged || (s.confirm_beyond_deg < 0 && s.confirm_beyond_m < 0)) return "";
  const Vector6d moved = poseError(lidar.T_cam_lidar, T_cam_lidar_init);
  const double moved_deg = moved.head<3>().norm() * kDegPerRad, moved_m = moved.tail<3>().norm();
  if (!((s.confirm_beyond_deg >= 0 && moved_deg >= s.confirm_beyond_deg) ||
        (s.confirm_beyond_m >= 0 && moved_m >= s.confirm_beyond_m)))
    return "";
  const auto t0 = Clock::now();
  LidarStereoSettings ls = settings;
  ls.run_coarse = true;
  ls.initial_stereo_scale = lidar.stereo_scale;  // the final clouds' scale and yaw, as found
  ls.initial_stereo_yaw_rad = lidar.stereo_yaw_rad;
  const LidarStereoResult again = solveLidarStereo(window, T_cam_lidar_init, ls);
  if (seconds) *seconds = secondsSince(t0);
  if (!again.converged) return ls.cancelled() ? "cancelled during the second opinion" : "";
  const Vector6d gap = poseError(again.T_cam_lidar, lidar.T_cam_lidar);
  const double gap_deg = gap.head<3>().norm() * kDegPerRad, gap_m = gap.tail<3>().norm();
  if (gap_deg <= s.confirm_disagree_deg && gap_m <= s.confirm_disagree_m) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "two minima: the estimate moved %.2f deg / %.2f m from the initial guess, and a "
                "solve from the initial guess with the final clouds converged %.2f deg / %.2f m "
                "away from it",
                moved_deg, moved_m, gap_deg, gap_m);
  return buf;
}

CoCalibrationResult coCalibrate(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                const Eigen::Isometry3d& T_cam_lidar_init,
                                const Eigen::Isometry3d& T_right_left_init,
                                const CoCalibrationSettings& s) {
  const auto t0 = Clock::now();
  const bool debug = std::getenv("TESCALIB_DEBUG") != nullptr;
  CoCalibrationResult res;
  res.lidar.T_cam_lidar = T_cam_lidar_init;
  res.stereo.T_right_left = T_right_left_init;
  const std::string pair_problem = stereoExtrinsicProblem(T_right_left_init);
  if (!pair_problem.empty() || !isRigidTransform(T_cam_lidar_init)) {
    res.message = !pair_problem.empty()
                      ? "initial guess: " + pair_problem
                      : "the initial T_cam_lidar is not a rigid transform (NaN, or not a rotation)";
    return res;
  }
  if (window.empty()) {
    res.message = "empty window";
    return res;
  }
  std::vector<const Keyframe*> cwin(window.begin(), window.end());
  Eigen::Isometry3d T_cl = T_cam_lidar_init, T_rl = T_right_left_init;
  // Estimates after each round since the last extrapolation (for Aitken's step).
  std::deque<std::pair<Eigen::Isometry3d, Eigen::Isometry3d>> history;
  double prev_step = std::numeric_limits<double>::infinity();
  bool photometric_done = false;
  // Free key point depth (free_depth_rounds) only while the LiDAR is far off; the final rounds
  // always use the LiDAR depth, which fixes the yaw far better.
  bool lidar_converged = false;  // in some round so far
  bool free_depth = false;       // this round's photometric solve had free depth
  bool free_depth_done = false;  // a free-depth round settled, or a LiDAR-stereo solve ran away
  bool lidar_accepted = false;   // a LiDAR-stereo estimate was taken (later rounds: fine only)
  bool lidar_settled = false;    // ... and its solve converged
  // |clouds' yaw| the last accepted LiDAR-stereo solve found (deg); inf: none yet
  double last_yaw_gap = std::numeric_limits<double>::infinity();
  double lidar_yaw = 0;  // its clouds' yaw nuisance, relative to lidar_yaw_clouds
  Eigen::Isometry3d lidar_yaw_clouds = Eigen::Isometry3d::Identity();
  // A round whose LiDAR-stereo estimate is not taken: the next one starts from these estimates,
  // and the stability criterion and the extrapolation start afresh.
  auto continueFrom = [&](const Eigen::Isometry3d& cl, const Eigen::Isometry3d& rl) {
    T_cl = cl, T_rl = rl;
    res.lidar.converged = false;
    res.lidar.T_cam_lidar = T_cl;
    res.stereo.T_right_left = T_rl;
    prev_step = std::numeric_limits<double>::infinity();
    history.clear();
  };
  LidarStereoSettings ls_last = s.lidar;  // the settings of the last LiDAR-stereo solve
  // LiDAR first (lidar_first_fallback): LiDAR-stereo from the initial guess with the wide-basin
  // search, on the clouds as they are now.
  auto lidarFirst = [&](LidarStereoSettings ls) {
    ls.run_coarse = true;
    ls.initial_stereo_yaw_rad = 0;
    res.lidar_first = true;
    return solveLidarStereoSearch(cwin, T_cam_lidar_init, ls);
  };
  auto ranAway = [&](const LidarStereoResult& r, const LidarStereoSettings& ls, Vector6d* from) {
    *from = poseError(r.T_cam_lidar, T_cam_lidar_init);
    return !from->allFinite() || !std::isfinite(r.stereo_scale) ||
           from->head<3>().norm() * kDegPerRad > ls.max_correction_rot_deg ||
           from->tail<3>().norm() > ls.max_correction_trans_m;
  };
  // Stereo from features: round 1 starts from the matches' pair and solves LiDAR-stereo first.
  bool features_first = false;
  if (s.stereo_from_features && !s.lidar.cancelled()) {
    res.features = estimateStereoFromFeatures(cwin, rig, T_rl, s.features);
    features_first = res.features.ok;
    if (features_first) T_rl = res.stereo.T_right_left = res.features.T_right_left;
    if (debug) {
      const Vector6d moved = poseError(res.features.T_right_left, T_right_left_init);
      std::fprintf(stderr,
                   "co features: %d matches, %d inliers, rms %.3f px, sigma %.4f deg / %.3f deg "
                   "(direction), %.2f s; moved the pair %.3f deg / %.2f cm%s%s\n",
                   res.features.matches, res.features.inliers, res.features.rms_px,
                   res.features.sigma_rot_deg, res.features.sigma_direction_deg,
                   res.features.seconds, moved.head<3>().norm() * kDegPerRad,
                   moved.tail<3>().norm() * 100, features_first ? "" : ": not used, ",
                   res.features.message.c_str());
    }
  }
  bool rejected_last = false;  // the last round's LiDAR-stereo estimate was not taken
  bool stuck = false;  // ... and this one's, from the same estimates and clouds: nothing changes
  // A left-right estimate the clouds cannot be rectified with (a photometric solve lost far
  // off, its baseline turned more vertical than horizontal): the alternation stops there.
  std::string unrectifiable;
  auto cannotRectify = [&](const Eigen::Isometry3d& T) {
    if (rectifiedBaseline(rig, T) > 0) return false;
    const Eigen::Vector3d t = T.translation().normalized();
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "the left-right estimate of round %d cannot be rectified side by side (its "
                  "baseline %.1f deg from the camera's -x axis; left-right: ",
                  res.rounds, std::acos(std::clamp(-t.x(), -1.0, 1.0)) * kDegPerRad);
    unrectifiable = buf + (res.stereo.converged ? "converged" : res.stereo.message) + ")";
    return true;
  };
  for (res.rounds = 1; res.rounds <= s.max_rounds; ++res.rounds) {
    if (s.lidar.cancelled()) {  // LidarStereoSettings::cancel: before each round too
      res.converged = false;
      res.message = "cancelled";
      res.rounds -= 1;  // the rounds that ran
      return res;
    }
    const bool warm = s.warm_start && (res.rounds > 1 || s.warm_first_round);
    Eigen::Isometry3d T_rl_new = T_rl;
    bool lidar_first_now = false;         // this round tries LiDAR first
    Eigen::Isometry3d T_rl_first = T_rl;  // ... on clouds rectified with this
    // 1. Left-right from the LiDAR depth (not in the round that starts from the features' pair).
    const bool features_round = features_first && res.rounds == 1;
    if (!features_round) {
      PhotometricSettings ps =
          coPhotometricSettings(s, warm && (photometric_done || s.warm_first_round));
      free_depth = res.rounds <= s.free_depth_rounds && !lidar_converged && !free_depth_done;
      if (free_depth) ps.depth_prior_sigma = s.free_depth_prior_sigma;
      const auto t_ph = Clock::now();
      res.stereo = solvePhotometric(cwin, rig, T_cl, T_rl, ps);
      res.seconds_photometric += secondsSince(t_ph);
      photometric_done = true;
      // The photometric baseline length is only as good as the LiDAR depth it used: keep the
      // current length (set by the LiDAR-given stereo scale after round 1) and take the rotation
      // and the baseline direction.
      T_rl_new = res.stereo.T_right_left;
      if (debug)
        std::fprintf(stderr, "co round %d: photometric |t| %.4f (given %.4f), %s\n", res.rounds,
                     T_rl_new.translation().norm(), T_rl.translation().norm(),
                     res.stereo.converged ? "converged" : res.stereo.message.c_str());
      if (res.rounds > 1)
        T_rl_new.translation() = T_rl_new.translation().normalized() * T_rl.translation().norm();
      // A pose that matched nothing but texture, or a jump beyond the solver's bounds: the key
      // points' LiDAR depth is too far off for the left-right solve: try LiDAR first, from the
      // initial guess, on clouds rectified with its rotation (image motion under rotation does
      // not depend on depth: generated starts 1 deg off went to 0.2-0.3 deg; not when it
      // diverged) and the baseline from before (its direction does depend on depth: 22 deg off on
      // one).
      const Vector6d ph_step = poseError(res.stereo.T_right_left, T_rl);
      const bool diverged = ph_step.head<3>().norm() * kDegPerRad > ps.max_correction_rot_deg ||
                            ph_step.tail<3>().norm() > ps.max_correction_trans_m;
      lidar_first_now = s.lidar_first_fallback && !lidar_converged && !res.lidar_first &&
                        (diverged || !(res.stereo.consistency_ratio <= ps.max_consistency_ratio));
      if (lidar_first_now) {
        T_rl_first.linear() = diverged ? T_rl.linear() : T_rl_new.linear();
        T_rl_first.translation() = T_rl.translation();
      }
    }
    // The inner LiDAR-stereo solves only need to settle well below the outer tolerance (its
    // defaults, 2e-4 deg and 0.02 mm, are below what re-association noise allows with the scale
    // free); the split-window check runs once, on the final estimate.
    LidarStereoSettings ls = coLidarStereoSettings(s);
    ls.check_window_halves = false;
    ls.converge_rot_deg = std::max(ls.converge_rot_deg, s.inner_settle_fraction * s.stable_rot_deg);
    ls.converge_trans_m = std::max(ls.converge_trans_m, s.inner_settle_fraction * s.stable_trans_m);
    // ... and the fine stage, which stops on fine_settle_* (converge_* is the coarse stage's; until
    // session 32 only the defaults' coincidence, 0.1 x 0.01 deg / 3 mm, made this hold).
    ls.fine_settle_rot_deg = s.inner_settle_fraction * s.stable_rot_deg;
    ls.fine_settle_trans_m = s.inner_settle_fraction * s.stable_trans_m;
    const LidarStereoSettings ls_first = ls;
    int rectified = 0;  // keyframes whose clouds this round recomputed
    auto rectify = [&](const Eigen::Isometry3d& T) {
      if (debug) {
        const RectificationChange c = rectificationChange(window.front()->T_right_left_used, T);
        const Eigen::Vector3d phi = c.phi * kDegPerRad, dir = c.direction * kDegPerRad;
        std::fprintf(stderr,
                     "co round %d: vs clouds: rot [%.4f %.4f %.4f] deg, direction dy %.4f dz "
                     "%.4f deg\n",
                     res.rounds, phi.x(), phi.y(), phi.z(), dir.y(), dir.z());
      }
      const int n = rectifyWindow(window, rig, T, s.stereo_cloud, rectifyTolerances(s),
                                  &res.seconds_stereo_cloud, &res.rematches);
      res.rectifications += n > 0;
      rectified += n;
    };
    // A LiDAR-first solve is taken when it converged within the divergence bounds; otherwise the
    // round goes on as it would have without it.
    auto tryLidarFirst = [&](const char* why) {
      const auto t_l = Clock::now();
      const LidarStereoResult r = lidarFirst(ls_first);
      res.seconds_lidar += secondsSince(t_l);
      Vector6d from;
      const bool take = r.converged && !ranAway(r, ls_first, &from);
      if (debug)
        std::fprintf(stderr, "co round %d: %s: LiDAR first, from the initial guess: %s\n",
                     res.rounds, why,
                     take ? "converged, taken" : ("not taken: " + r.message).c_str());
      if (take) res.lidar = r, ls_last = ls_first;
      return take;
    };
    if (lidar_first_now && cannotRectify(T_rl_first)) break;
    if (lidar_first_now) {
      rectify(T_rl_first);
      if (tryLidarFirst("the photometric solve failed with this LiDAR depth")) {
        T_rl_new = T_rl_first;
        photometric_done = false;  // the next photometric solve starts cold again
      } else {
        lidar_first_now = false;
      }
    }
    // 2. Stereo clouds, only where the rectification changed enough to matter.
    if (!lidar_first_now && cannotRectify(T_rl_new)) break;
    if (!lidar_first_now) rectify(T_rl_new);
    const double b_used = window.front()->T_right_left_used.translation().norm();
    // 3. LiDAR-stereo with the stereo scale: the LiDAR is metric, so the scale corrects the
    // baseline length (rectification does not depend on it, the clouds simply scale).
    if (warm && lidar_accepted) {
      // Fine stage only after a solve that converged: from an estimate a degenerate or unsettled
      // solve left far off, the fine stage alone creeps back by ~0.1 m per round.
      ls.run_coarse = !lidar_settled;
      // The clouds' yaw relative to the right camera, as the last solve found it, carried over
      // to the rectification the clouds have now.
      if (ls.estimate_stereo_yaw)
        ls.initial_stereo_yaw_rad =
            lidar_yaw -
            rectificationChange(lidar_yaw_clouds, window.front()->T_right_left_used).phi.y();
    }
    // A LiDAR estimate implausibly far from the initial guess (the solver's own divergence
    // bounds, counted from the start of the alternation) is not taken: the round is repeated from
    // the previous estimates with the LiDAR depth (a free-depth round can hand it clouds rectified
    // with a yaw far off, from which a start 3 deg off can run away on real data). Before any
    // LiDAR-stereo solve has converged, LiDAR first is tried on these clouds first.
    Vector6d from_init;
    if (!lidar_first_now) {
      ls_last = ls;
      const auto t_l = Clock::now();
      res.lidar = features_round ? solveLidarStereoSearch(cwin, T_cl, ls)
                                 : solveLidarStereo(cwin, T_cl, ls);
      res.seconds_lidar += secondsSince(t_l);
      if (ranAway(res.lidar, ls, &from_init) && s.lidar_first_fallback && !lidar_converged &&
          !res.lidar_first)
        tryLidarFirst("LiDAR-stereo ran away");
    }
    if (ranAway(res.lidar, ls, &from_init)) {
      ++res.rejected;
      if (debug)
        std::fprintf(stderr, "co round %d: LiDAR-stereo ran away (%.2f deg, %.2f m): rejected\n",
                     res.rounds, from_init.head<3>().norm() * kDegPerRad,
                     from_init.tail<3>().norm());
      free_depth_done = true;
      // The same clouds and the same start as the last rejected round: the next rounds would
      // repeat it (a session-27 start 10 deg / 1 m off did, 14 times in 35 s).
      stuck = rejected_last && rectified == 0;
      rejected_last = true;
      continueFrom(T_cl, T_rl);
      if (stuck) break;
      continue;
    }
    rejected_last = false;
    const double yaw_gap = std::fabs(res.lidar.stereo_yaw_rad) * kDegPerRad;
    if (ls.estimate_stereo_yaw && s.yaw_handover_deg >= 0 && yaw_gap > s.yaw_handover_deg &&
        yaw_gap >= last_yaw_gap && res.yaw_handovers < s.max_yaw_handovers) {
      // The solvers disagree on the right camera's yaw, and the disagreement did not shrink since
      // the last round (it does when the photometric yaw is merely pulled by a LiDAR still far
      // off): the photometric yaw sits in a wrong minimum, and the estimates since were built on
      // it. Turn the right camera (about its centre) to the LiDAR-stereo yaw and start again from
      // there, with the initial LiDAR extrinsic and baseline length.
      const double delta = res.lidar.stereo_yaw_rad -
                           rectificationChange(window.front()->T_right_left_used, T_rl_new).phi.y();
      const Eigen::Matrix3d E = expSO3(Eigen::Vector3d(0, delta, 0));
      T_rl_new.linear() = E * T_rl_new.linear();
      T_rl_new.translation() =
          E * T_rl_new.translation().normalized() * T_right_left_init.translation().norm();
      ++res.yaw_handovers;
      if (debug)
        std::fprintf(
            stderr,
            "co round %d: LiDAR-stereo yaw %.4f deg (last round %.4f): right camera turned "
            "by %.4f deg, starting again from the initial LiDAR extrinsic\n",
            res.rounds, res.lidar.stereo_yaw_rad * kDegPerRad, last_yaw_gap, delta * kDegPerRad);
      continueFrom(T_cam_lidar_init, T_rl_new);
      lidar_accepted = lidar_settled = lidar_converged = false;
      last_yaw_gap = std::numeric_limits<double>::infinity();
      continue;
    }
    last_yaw_gap = yaw_gap;
    lidar_accepted = true;
    lidar_settled = res.lidar.converged;
    lidar_converged = lidar_converged || res.lidar.converged;
    lidar_yaw = res.lidar.stereo_yaw_rad;
    lidar_yaw_clouds = window.front()->T_right_left_used;
    if (debug && ls.estimate_stereo_yaw)
      std::fprintf(stderr, "co round %d: LiDAR-stereo yaw started at %.4f deg, ended at %.4f deg\n",
                   res.rounds, ls.initial_stereo_yaw_rad * kDegPerRad, lidar_yaw * kDegPerRad);
    T_rl_new.translation() = T_rl_new.translation().normalized() * res.lidar.stereo_scale * b_used;
    res.stereo.T_right_left = T_rl_new;
    const Eigen::Isometry3d T_cl_new = res.lidar.T_cam_lidar;

    // Stability: this round's step, and the remaining distance predicted from its contraction.
    const double step = stepSize(normalisedDifference(T_cl_new, T_rl_new, T_cl, T_rl, s));
    const double rho = step / prev_step;
    // A solve cancelled within the round returned its start: no step, but not stable either.
    bool stable = !s.lidar.cancelled() && res.rounds > 1 && photometric_done && step < 1.0 &&
                  (rho < 1.0 ? step * rho / (1.0 - rho) < 1.0 : prev_step < 1.0);
    if (free_depth && stable) {
      free_depth_done = true;  // settled with free depth: confirm with the LiDAR depth
      stable = false;
    }
    if (debug) {
      const Eigen::Vector3d r = logSO3(T_rl_new.linear()) * kDegPerRad;
      std::fprintf(
          stderr,
          "co round %d: scale %.4f yaw %.4f deg T_rl rot [%.4f %.4f %.4f] deg t [%.4f %.4f %.4f]; "
          "lidar %s %s; T_cl t [%.4f %.4f %.4f]; step %.2f rho %.2f%s; s: photo %.2f "
          "cloud %.2f lidar %.2f\n",
          res.rounds, res.lidar.stereo_scale, res.lidar.stereo_yaw_rad * kDegPerRad, r.x(), r.y(),
          r.z(), T_rl_new.translation().x(), T_rl_new.translation().y(), T_rl_new.translation().z(),
          res.lidar.converged ? "conv" : "not conv", res.lidar.message.c_str(),
          T_cl_new.translation().x(), T_cl_new.translation().y(), T_cl_new.translation().z(), step,
          rho, stable ? " stable" : "", res.seconds_photometric, res.seconds_stereo_cloud,
          res.seconds_lidar);
    }
    T_cl = T_cl_new, T_rl = T_rl_new;
    prev_step = step;
    if (stable) {
      res.stable = true;
      break;
    }
    // Aitken's delta-squared on the stacked estimates: the alternation is a contraction whose
    // dominant rate rho shows in successive steps; the fixed point is x2 + rho / (1 - rho) d2.
    if (res.rounds > 1) history.emplace_back(T_cl, T_rl);  // round 1 includes the coarse stage
    if (s.extrapolate && history.size() == 3) {
      const auto& [cl0, rl0] = history[0];
      const auto& [cl1, rl1] = history[1];
      const Vector12d x0 = normalisedDifference(cl0, rl0, T_cl, T_rl, s);
      const Vector12d x1 = normalisedDifference(cl1, rl1, T_cl, T_rl, s);
      const Vector12d d1 = x1 - x0, d2 = -x1;
      const double r = d2.dot(d1) / std::max(1e-12, d1.squaredNorm());
      const double cosine = d2.dot(d1) / std::max(1e-12, d1.norm() * d2.norm());
      history.pop_front();
      // Only a consistent contraction of solves that converged, and never a jump larger than
      // the last three steps together (a wrong rate estimate must not throw the estimate away).
      if (r > 0 && r < s.max_contraction && cosine > 0.8 && res.lidar.converged &&
          res.stereo.converged) {
        const Vector12d jump = r / (1.0 - r) * d2;
        T_cl = applyNormalised(T_cl, jump.head<6>(), s);
        T_rl = applyNormalised(T_rl, jump.tail<6>(), s);
        ++res.extrapolations;
        history.clear();
        prev_step = std::numeric_limits<double>::infinity();  // the next step is judged afresh
        if (debug)
          std::fprintf(stderr, "co extrapolation: rho %.2f, cosine %.2f, jump %.2f\n", r, cosine,
                       stepSize(jump));
      }
    }
  }
  res.rounds = std::min(res.rounds, s.max_rounds);
  if (s.lidar.cancelled()) {  // within the last round: its solves returned their starts
    res.converged = false;
    res.message = "cancelled";
    return res;
  }
  // The split-window check of the LiDAR-stereo noise model, on the final estimate (the clouds are
  // still those the last solve used; also after an unstable run, for the online node's warm
  // rounds, which take a converged LiDAR-stereo solve as it is).
  if (res.lidar.converged && s.lidar.check_window_halves) {
    const auto t_h = Clock::now();
    checkWindowHalves(cwin, ls_last, &res.lidar);
    res.seconds_lidar += secondsSince(t_h);
  }
  // A converged estimate far from the initial guess gets a second opinion from there.
  if (res.stable && res.lidar.converged) {
    double seconds = 0;
    const std::string doubt =
        secondOpinion(cwin, T_cam_lidar_init, res.lidar, ls_last, s, &seconds);
    res.seconds_lidar += seconds;
    if (debug && seconds > 0)
      std::fprintf(stderr, "co second opinion (%.2f s): %s\n", seconds,
                   doubt.empty() ? "agrees or did not converge" : doubt.c_str());
    if (!doubt.empty()) res.lidar.converged = false, res.lidar.message = doubt;
  }
  coCalibrationCovariances(window, rig, ls_last, s, &res);
  res.converged = res.stable && res.lidar.converged && res.stereo.converged;
  if (!unrectifiable.empty())
    res.converged = false, res.message = unrectifiable;
  else if (stuck)
    res.message = "LiDAR-stereo ran away from the initial guess in " +
                  std::to_string(res.rejected) +
                  " rounds, the last two started from the same estimates and clouds (a start "
                  "beyond the basin?)";
  else if (!res.stable)
    res.message = "estimates still moving after " + std::to_string(s.max_rounds) + " rounds" +
                  (res.rejected ? " (" + std::to_string(res.rejected) +
                                      " LiDAR-stereo estimates ran away from the initial guess "
                                      "and were not taken)"
                                : "");
  else if (!res.stereo.converged)
    res.message = "left-right: " + res.stereo.message;
  else if (!res.lidar.converged)
    res.message = "LiDAR-stereo: " + res.lidar.message;
  // Cancelled after the rounds: the split-window check, the second opinion or the sensitivity to
  // the pair may have been cut short (review, session 37; jointCalibrate does the same).
  if (s.lidar.cancelled()) res.converged = false, res.message = "cancelled";
  res.seconds = secondsSince(t0);
  return res;
}

}  // namespace tescalib
