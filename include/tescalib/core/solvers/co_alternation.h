// Co-calibration's alternation (paper, "Co-calibration") as a state machine. Each round solves
// the left-right extrinsic (photometrically, or in round 1 from feature matches), brings the
// stereo clouds to it, solves LiDAR-stereo on them, judges the LiDAR estimate and tests both
// estimates for stability. coCalibrate runs it, then checks the final estimate and computes the
// covariances.
#pragma once

#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "tescalib/core/solvers/co_calibration.h"

namespace tescalib {

/// The phases of the alternation; each step runs one and names the next (CoAlternation::step).
enum class CoPhase {
  kStereoFromFeatures,     ///< before round 1: the pair's rotation and direction from matches
  kRoundStart,             ///< out of rounds or cancelled; else the round's settings
  kPhotometricFreeDepth,   ///< left-right photometric, key point depth free (free_depth_rounds)
  kPhotometricLidarDepth,  ///< left-right photometric on the LiDAR depth
  kLidarFirst,             ///< LiDAR-stereo from the initial guess (lidar_first_fallback)
  kLidarStereo,            ///< LiDAR-stereo with the stereo scale on the round's clouds
  kJudgeLidar,             ///< the LiDAR estimate: taken, rejected (ran away) or a yaw handover
  kSettling,               ///< stability test and Aitken extrapolation
  kNextRound,              ///< the round is over
  kDone,                   ///< stable, stuck, unrectifiable or out of rounds
  kCancelled,              ///< cancelled before a round
};

/// What one round of the alternation works with.
struct CoRound {
  bool warm = false;        ///< warm-started solves (CoCalibrationSettings::warm_start)
  bool features = false;    ///< round 1 from the features' pair: no photometric solve
  bool free_depth = false;  ///< the photometric solve gives the key points' depth freedom
  Eigen::Isometry3d T_rl_new = Eigen::Isometry3d::Identity();    ///< the round's left-right
  Eigen::Isometry3d T_rl_first = Eigen::Isometry3d::Identity();  ///< LiDAR first's clouds' one
  LidarStereoSettings lidar_settings;        ///< the LiDAR-stereo solve's (warm: fine stage, ...)
  LidarStereoSettings lidar_first_settings;  ///< LiDAR first's (the round's, before warm)
  int rectified = 0;                         ///< keyframes whose clouds the round recomputed
  double b_used = 0;                         ///< the clouds' baseline length for the scale
  Vector6d from_init = Vector6d::Zero();     ///< the LiDAR estimate's move from the initial guess
};

/// The alternation's state across rounds, and its steps. `res` receives the solves' results and
/// the counters as they happen.
struct CoAlternation {
  CoAlternation(const std::vector<Keyframe*>& window, const StereoRig& rig,
                const Eigen::Isometry3d& T_cam_lidar_init,
                const Eigen::Isometry3d& T_right_left_init, const CoCalibrationSettings& s,
                CoCalibrationResult* res);

  /// Runs the phases until kDone or kCancelled and returns that one.
  CoPhase run();
  /// Runs `phase`; returns the next.
  CoPhase step(CoPhase phase);

  // The steps, one per phase.
  CoPhase stereoFromFeatures();
  CoPhase startRound();
  CoPhase photometricStep(bool free_depth);
  CoPhase lidarFirstStep();
  CoPhase lidarStereoStep();
  CoPhase judgeLidar();
  CoPhase settle();

  // The transitions out of judgeLidar and settle.
  CoPhase rejectLidar();
  CoPhase handOverYaw();
  void acceptLidar();
  void extrapolate();

  // What the steps share.
  void continueFrom(const Eigen::Isometry3d& cl, const Eigen::Isometry3d& rl);
  bool ranAway(const LidarStereoResult& r, const LidarStereoSettings& ls, Vector6d* from) const;
  bool cannotRectify(const Eigen::Isometry3d& T);
  void rectify(const Eigen::Isometry3d& T);
  void startLidarStereo();
  bool tryLidarFirst(const char* why);

  const std::vector<Keyframe*>& window;
  const std::vector<const Keyframe*> cwin;
  const StereoRig& rig;
  const Eigen::Isometry3d T_cam_lidar_init, T_right_left_init;
  const CoCalibrationSettings& s;
  CoCalibrationResult& res;
  const bool debug;

  Eigen::Isometry3d T_cl, T_rl;  ///< the estimates after the last round
  /// Estimates after each round since the last extrapolation (for Aitken's step).
  std::deque<std::pair<Eigen::Isometry3d, Eigen::Isometry3d>> history;
  double prev_step;  ///< the last round's step (normalised; inf: judged afresh)
  bool photometric_done = false;
  bool features_first = false;  ///< round 1 starts from the features' pair
  // Free key point depth (free_depth_rounds) only while the LiDAR is far off; the final rounds
  // always use the LiDAR depth, which fixes the yaw far better.
  bool lidar_converged = false;  ///< in some round so far
  bool free_depth_done = false;  ///< a free-depth round settled, or a LiDAR-stereo solve ran away
  bool lidar_accepted = false;   ///< a LiDAR-stereo estimate was taken (later rounds: fine only)
  bool lidar_settled = false;    ///< ... and its solve converged
  double last_yaw_gap;           ///< |clouds' yaw| the last taken solve found (deg); inf: none
  double lidar_yaw = 0;          ///< its clouds' yaw nuisance, relative to lidar_yaw_clouds
  Eigen::Isometry3d lidar_yaw_clouds = Eigen::Isometry3d::Identity();
  bool rejected_last = false;  ///< the last round's LiDAR-stereo estimate was not taken
  bool stuck = false;  ///< ... and this one's, from the same estimates and clouds: nothing changes
  /// Why the alternation stopped at a left-right estimate the clouds cannot be rectified with
  /// (empty: it did not).
  std::string unrectifiable;
  LidarStereoSettings ls_last;  ///< the settings of the last LiDAR-stereo solve
  CoRound round;                ///< the current round
};

}  // namespace tescalib
