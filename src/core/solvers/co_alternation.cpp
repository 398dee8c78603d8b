#include "tescalib/core/solvers/co_alternation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/timing.h"

namespace tescalib {

namespace {

using Clock = std::chrono::steady_clock;

using Vector12d = Eigen::Matrix<double, 12, 1>;

constexpr double kInf = std::numeric_limits<double>::infinity();

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
  if (!x.allFinite()) return kInf;  // never "stable"
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

/// The settings of the alternation's LiDAR-stereo solves before the warm start's changes.
LidarStereoSettings innerLidarSettings(const CoCalibrationSettings& s) {
  // The inner LiDAR-stereo solves only need to settle well below the outer tolerance (its
  // defaults, 2e-4 deg and 0.02 mm, are below what re-association noise allows with the scale
  // free); the split-window check runs once, on the final estimate.
  LidarStereoSettings ls = coLidarStereoSettings(s);
  ls.check_window_halves = false;
  ls.converge_rot_deg = std::max(ls.converge_rot_deg, s.inner_settle_fraction * s.stable_rot_deg);
  ls.converge_trans_m = std::max(ls.converge_trans_m, s.inner_settle_fraction * s.stable_trans_m);
  // ... and the fine stage, which stops on fine_settle_* (converge_* is the coarse stage's).
  ls.fine_settle_rot_deg = s.inner_settle_fraction * s.stable_rot_deg;
  ls.fine_settle_trans_m = s.inner_settle_fraction * s.stable_trans_m;
  return ls;
}

}  // namespace

CoAlternation::CoAlternation(const std::vector<Keyframe*>& window_, const StereoRig& rig_,
                             const Eigen::Isometry3d& T_cam_lidar_init_,
                             const Eigen::Isometry3d& T_right_left_init_,
                             const CoCalibrationSettings& s_, CoCalibrationResult* res_)
    : window(window_),
      cwin(window_.begin(), window_.end()),
      rig(rig_),
      T_cam_lidar_init(T_cam_lidar_init_),
      T_right_left_init(T_right_left_init_),
      s(s_),
      res(*res_),
      debug(std::getenv("TESCALIB_DEBUG") != nullptr),
      T_cl(T_cam_lidar_init_),
      T_rl(T_right_left_init_),
      prev_step(kInf),
      last_yaw_gap(kInf),
      ls_last(s_.lidar) {}

CoPhase CoAlternation::run() {
  res.rounds = 1;
  CoPhase phase = s.stereo_from_features ? CoPhase::kStereoFromFeatures : CoPhase::kRoundStart;
  while (phase != CoPhase::kDone && phase != CoPhase::kCancelled) phase = step(phase);
  return phase;
}

CoPhase CoAlternation::step(CoPhase phase) {
  switch (phase) {
    case CoPhase::kStereoFromFeatures:
      return stereoFromFeatures();
    case CoPhase::kRoundStart:
      return startRound();
    case CoPhase::kPhotometricFreeDepth:
      return photometricStep(true);
    case CoPhase::kPhotometricLidarDepth:
      return photometricStep(false);
    case CoPhase::kLidarFirst:
      return lidarFirstStep();
    case CoPhase::kLidarStereo:
      return lidarStereoStep();
    case CoPhase::kJudgeLidar:
      return judgeLidar();
    case CoPhase::kSettling:
      return settle();
    case CoPhase::kNextRound:
      ++res.rounds;
      return CoPhase::kRoundStart;
    case CoPhase::kDone:
    case CoPhase::kCancelled:
      break;
  }
  return phase;
}

// Stereo from features: round 1 starts from the matches' pair and solves LiDAR-stereo first.
CoPhase CoAlternation::stereoFromFeatures() {
  if (s.lidar.cancelled()) return CoPhase::kRoundStart;  // which stops on the cancel
  res.features = estimateStereoFromFeatures(cwin, rig, T_rl, s.features);
  features_first = res.features.ok;
  if (features_first) T_rl = res.stereo.T_right_left = res.features.T_right_left;
  if (debug) {
    const Vector6d moved = poseError(res.features.T_right_left, T_right_left_init);
    std::fprintf(stderr,
                 "co features: %d matches, %d inliers, rms %.3f px, sigma %.4f deg / %.3f deg "
                 "(direction), %.2f s; moved the pair %.3f deg / %.2f cm%s%s\n",
                 res.features.matches, res.features.inliers, res.features.rms_px,
                 res.features.sigma_rot_deg, res.features.sigma_direction_deg, res.features.seconds,
                 moved.head<3>().norm() * kDegPerRad, moved.tail<3>().norm() * 100,
                 features_first ? "" : ": not used, ", res.features.message.c_str());
  }
  return CoPhase::kRoundStart;
}

CoPhase CoAlternation::startRound() {
  if (res.rounds > s.max_rounds) return CoPhase::kDone;
  if (s.lidar.cancelled()) {  // LidarStereoSettings::cancel: before each round too
    res.rounds -= 1;          // the rounds that ran
    return CoPhase::kCancelled;
  }
  round = CoRound();
  round.warm = s.warm_start && (res.rounds > 1 || s.warm_first_round);
  round.T_rl_new = round.T_rl_first = T_rl;
  round.lidar_settings = round.lidar_first_settings = innerLidarSettings(s);
  // Left-right from the LiDAR depth, except in the round that starts from the features' pair.
  round.features = features_first && res.rounds == 1;
  if (round.features) return CoPhase::kLidarStereo;
  const bool free_depth = res.rounds <= s.free_depth_rounds && !lidar_converged && !free_depth_done;
  return free_depth ? CoPhase::kPhotometricFreeDepth : CoPhase::kPhotometricLidarDepth;
}

CoPhase CoAlternation::photometricStep(bool free_depth) {
  PhotometricSettings ps =
      coPhotometricSettings(s, round.warm && (photometric_done || s.warm_first_round));
  round.free_depth = free_depth;
  if (free_depth) ps.depth_prior_sigma = s.free_depth_prior_sigma;
  const auto t_ph = Clock::now();
  res.stereo = solvePhotometric(cwin, rig, T_cl, T_rl, ps);
  res.seconds_photometric += secondsSince(t_ph);
  photometric_done = true;
  // The photometric baseline length is only as good as the LiDAR depth it used: keep the
  // current length (set by the LiDAR-given stereo scale after round 1) and take the rotation
  // and the baseline direction.
  Eigen::Isometry3d& T_rl_new = round.T_rl_new;
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
  const bool lidar_first =
      s.lidar_first_fallback && !lidar_converged && !res.lidar_first &&
      (diverged || !(res.stereo.consistency_ratio <= ps.max_consistency_ratio));
  if (!lidar_first) return CoPhase::kLidarStereo;
  round.T_rl_first.linear() = diverged ? T_rl.linear() : T_rl_new.linear();
  round.T_rl_first.translation() = T_rl.translation();
  return CoPhase::kLidarFirst;
}

CoPhase CoAlternation::lidarFirstStep() {
  if (cannotRectify(round.T_rl_first)) return CoPhase::kDone;
  rectify(round.T_rl_first);
  if (!tryLidarFirst("the photometric solve failed with this LiDAR depth"))
    return CoPhase::kLidarStereo;
  round.T_rl_new = round.T_rl_first;
  photometric_done = false;  // the next photometric solve starts cold again
  startLidarStereo();
  return CoPhase::kJudgeLidar;
}

CoPhase CoAlternation::lidarStereoStep() {
  // Stereo clouds, only where the rectification changed enough to matter.
  if (cannotRectify(round.T_rl_new)) return CoPhase::kDone;
  rectify(round.T_rl_new);
  startLidarStereo();
  // LiDAR-stereo with the stereo scale: the LiDAR is metric, so the scale corrects the
  // baseline length (rectification does not depend on it, the clouds simply scale).
  const LidarStereoSettings& ls = round.lidar_settings;
  ls_last = ls;
  const auto t_l = Clock::now();
  res.lidar =
      round.features ? solveLidarStereoSearch(cwin, T_cl, ls) : solveLidarStereo(cwin, T_cl, ls);
  res.seconds_lidar += secondsSince(t_l);
  // Before any LiDAR-stereo solve has converged, LiDAR first is tried on these clouds when the
  // estimate ran away.
  if (ranAway(res.lidar, ls, &round.from_init) && s.lidar_first_fallback && !lidar_converged &&
      !res.lidar_first)
    tryLidarFirst("LiDAR-stereo ran away");
  return CoPhase::kJudgeLidar;
}

// What the round's LiDAR-stereo estimate starts from: the clouds' baseline length (the stereo
// scale's reference) and, warm, the last taken solve's stage and clouds' yaw.
void CoAlternation::startLidarStereo() {
  round.b_used = window.front()->T_right_left_used.translation().norm();
  if (!(round.warm && lidar_accepted)) return;
  LidarStereoSettings& ls = round.lidar_settings;
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

// A LiDAR estimate implausibly far from the initial guess (the solver's own divergence bounds,
// counted from the start of the alternation) is not taken: the round is repeated from the
// previous estimates with the LiDAR depth (a free-depth round can hand it clouds rectified with a
// yaw far off, from which a start 3 deg off can run away on real data). A LiDAR-stereo yaw that
// keeps disagreeing with the photometric one hands the yaw over; otherwise the estimate is taken.
CoPhase CoAlternation::judgeLidar() {
  if (ranAway(res.lidar, round.lidar_settings, &round.from_init)) return rejectLidar();
  rejected_last = false;
  const double yaw_gap = std::fabs(res.lidar.stereo_yaw_rad) * kDegPerRad;
  if (round.lidar_settings.estimate_stereo_yaw && s.yaw_handover_deg >= 0 &&
      yaw_gap > s.yaw_handover_deg && yaw_gap >= last_yaw_gap &&
      res.yaw_handovers < s.max_yaw_handovers)
    return handOverYaw();
  last_yaw_gap = yaw_gap;
  acceptLidar();
  return CoPhase::kSettling;
}

CoPhase CoAlternation::rejectLidar() {
  ++res.rejected;
  if (debug)
    std::fprintf(stderr, "co round %d: LiDAR-stereo ran away (%.2f deg, %.2f m): rejected\n",
                 res.rounds, round.from_init.head<3>().norm() * kDegPerRad,
                 round.from_init.tail<3>().norm());
  free_depth_done = true;
  // The same clouds and the same start as the last rejected round: the next rounds would repeat
  // it (a start 10 deg / 1 m off did, 14 times in 35 s).
  stuck = rejected_last && round.rectified == 0;
  rejected_last = true;
  continueFrom(T_cl, T_rl);
  return stuck ? CoPhase::kDone : CoPhase::kNextRound;
}

// The solvers disagree on the right camera's yaw, and the disagreement did not shrink since the
// last round (it does when the photometric yaw is merely pulled by a LiDAR still far off): the
// photometric yaw sits in a wrong minimum, and the estimates since were built on it. Turn the
// right camera (about its centre) to the LiDAR-stereo yaw and start again from there, with the
// initial LiDAR extrinsic and baseline length.
CoPhase CoAlternation::handOverYaw() {
  Eigen::Isometry3d& T_rl_new = round.T_rl_new;
  const double delta = res.lidar.stereo_yaw_rad -
                       rectificationChange(window.front()->T_right_left_used, T_rl_new).phi.y();
  const Eigen::Matrix3d E = expSO3(Eigen::Vector3d(0, delta, 0));
  T_rl_new.linear() = E * T_rl_new.linear();
  T_rl_new.translation() =
      E * T_rl_new.translation().normalized() * T_right_left_init.translation().norm();
  ++res.yaw_handovers;
  if (debug)
    std::fprintf(stderr,
                 "co round %d: LiDAR-stereo yaw %.4f deg (last round %.4f): right camera turned "
                 "by %.4f deg, starting again from the initial LiDAR extrinsic\n",
                 res.rounds, res.lidar.stereo_yaw_rad * kDegPerRad, last_yaw_gap,
                 delta * kDegPerRad);
  continueFrom(T_cam_lidar_init, T_rl_new);
  lidar_accepted = lidar_settled = lidar_converged = false;
  last_yaw_gap = kInf;
  return CoPhase::kNextRound;
}

// The LiDAR-stereo estimate is taken; its stereo scale sets the baseline length.
void CoAlternation::acceptLidar() {
  lidar_accepted = true;
  lidar_settled = res.lidar.converged;
  lidar_converged = lidar_converged || res.lidar.converged;
  lidar_yaw = res.lidar.stereo_yaw_rad;
  lidar_yaw_clouds = window.front()->T_right_left_used;
  if (debug && round.lidar_settings.estimate_stereo_yaw)
    std::fprintf(stderr, "co round %d: LiDAR-stereo yaw started at %.4f deg, ended at %.4f deg\n",
                 res.rounds, round.lidar_settings.initial_stereo_yaw_rad * kDegPerRad,
                 lidar_yaw * kDegPerRad);
  Eigen::Isometry3d& T_rl_new = round.T_rl_new;
  T_rl_new.translation() =
      T_rl_new.translation().normalized() * res.lidar.stereo_scale * round.b_used;
  res.stereo.T_right_left = T_rl_new;
}

// Stability (paper: "until both of the extrinsic parameter estimations are stable"): this round's
// step, and the remaining distance predicted from its contraction.
CoPhase CoAlternation::settle() {
  const Eigen::Isometry3d T_cl_new = res.lidar.T_cam_lidar;
  const Eigen::Isometry3d& T_rl_new = round.T_rl_new;
  const double step = stepSize(normalisedDifference(T_cl_new, T_rl_new, T_cl, T_rl, s));
  const double rho = step / prev_step;
  // A solve cancelled within the round returned its start: no step, but not stable either.
  bool stable = !s.lidar.cancelled() && res.rounds > 1 && photometric_done && step < 1.0 &&
                (rho < 1.0 ? step * rho / (1.0 - rho) < 1.0 : prev_step < 1.0);
  if (round.free_depth && stable) {
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
    return CoPhase::kDone;
  }
  if (res.rounds > 1) history.emplace_back(T_cl, T_rl);  // round 1 includes the coarse stage
  if (s.extrapolate && history.size() == 3) extrapolate();
  return CoPhase::kNextRound;
}

// Aitken's delta-squared on the stacked estimates of the last three rounds: the alternation is a
// contraction whose dominant rate rho shows in successive steps; the fixed point is
// x2 + rho / (1 - rho) d2.
void CoAlternation::extrapolate() {
  const auto& [cl0, rl0] = history[0];
  const auto& [cl1, rl1] = history[1];
  const Vector12d x0 = normalisedDifference(cl0, rl0, T_cl, T_rl, s);
  const Vector12d x1 = normalisedDifference(cl1, rl1, T_cl, T_rl, s);
  const Vector12d d1 = x1 - x0, d2 = -x1;
  const double r = d2.dot(d1) / std::max(1e-12, d1.squaredNorm());
  const double cosine = d2.dot(d1) / std::max(1e-12, d1.norm() * d2.norm());
  history.pop_front();
  // Only a consistent contraction of solves that converged, and never a jump larger than the
  // last three steps together (a wrong rate estimate must not throw the estimate away).
  if (!(r > 0 && r < s.max_contraction && cosine > 0.8 && res.lidar.converged &&
        res.stereo.converged))
    return;
  const Vector12d jump = r / (1.0 - r) * d2;
  T_cl = applyNormalised(T_cl, jump.head<6>(), s);
  T_rl = applyNormalised(T_rl, jump.tail<6>(), s);
  ++res.extrapolations;
  history.clear();
  prev_step = kInf;  // the next step is judged afresh
  if (debug)
    std::fprintf(stderr, "co extrapolation: rho %.2f, cosine %.2f, jump %.2f\n", r, cosine,
                 stepSize(jump));
}

// A round whose LiDAR-stereo estimate is not taken: the next one starts from these estimates,
// and the stability criterion and the extrapolation start afresh.
void CoAlternation::continueFrom(const Eigen::Isometry3d& cl, const Eigen::Isometry3d& rl) {
  T_cl = cl, T_rl = rl;
  res.lidar.converged = false;
  res.lidar.T_cam_lidar = T_cl;
  res.stereo.T_right_left = T_rl;
  prev_step = kInf;
  history.clear();
}

bool CoAlternation::ranAway(const LidarStereoResult& r, const LidarStereoSettings& ls,
                            Vector6d* from) const {
  *from = poseError(r.T_cam_lidar, T_cam_lidar_init);
  return !from->allFinite() || !std::isfinite(r.stereo_scale) ||
         from->head<3>().norm() * kDegPerRad > ls.max_correction_rot_deg ||
         from->tail<3>().norm() > ls.max_correction_trans_m;
}

// A left-right estimate the clouds cannot be rectified with (a photometric solve lost far off,
// its baseline turned more vertical than horizontal): the alternation stops there.
bool CoAlternation::cannotRectify(const Eigen::Isometry3d& T) {
  if (rectifiedBaseline(rig, T) > 0) return false;
  const Eigen::Vector3d t = T.translation().normalized();
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "the left-right estimate of round %d cannot be rectified side by side (its "
                "baseline %.1f deg from the camera's -x axis; left-right: ",
                res.rounds, std::acos(std::clamp(-t.x(), -1.0, 1.0)) * kDegPerRad);
  unrectifiable = buf + (res.stereo.converged ? "converged" : res.stereo.message) + ")";
  return true;
}

void CoAlternation::rectify(const Eigen::Isometry3d& T) {
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
  round.rectified += n;
}

// LiDAR first (lidar_first_fallback): LiDAR-stereo from the initial guess with the wide-basin
// search, on the clouds as they are now. It is taken when it converged within the divergence
// bounds; otherwise the round goes on as it would have without it.
bool CoAlternation::tryLidarFirst(const char* why) {
  const auto t_l = Clock::now();
  LidarStereoSettings ls = round.lidar_first_settings;
  ls.run_coarse = true;
  ls.initial_stereo_yaw_rad = 0;
  res.lidar_first = true;
  const LidarStereoResult r = solveLidarStereoSearch(cwin, T_cam_lidar_init, ls);
  res.seconds_lidar += secondsSince(t_l);
  Vector6d from;
  const bool take = r.converged && !ranAway(r, round.lidar_first_settings, &from);
  if (debug)
    std::fprintf(stderr, "co round %d: %s: LiDAR first, from the initial guess: %s\n", res.rounds,
                 why, take ? "converged, taken" : ("not taken: " + r.message).c_str());
  if (take) res.lidar = r, ls_last = round.lidar_first_settings;
  return take;
}

}  // namespace tescalib
