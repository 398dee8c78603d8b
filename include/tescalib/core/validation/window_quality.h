// The quality scores of an online estimate (validation_set.h's criteria, which the solvers do not
// optimise) on the keyframes of the calibrator's window, against the initial extrinsics on the
// same keyframes: what the node publishes with each estimate. Each keyframe is prepared once (edge
// maps, blurred grey images, depth discontinuities) and its initial scores computed once (in
// advance by prepare(), or by the first score()), kept while it is passed in; the disparity
// criterion reads the keyframe's own stereo cloud (the one the solvers use), triangulated again
// from its matches for another left->right extrinsic.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/validation/validation.h"

namespace tescalib {

struct WindowQualityScores {
  int keyframes = 0;
  FrameScores estimate, initial;  ///< per criterion, per keyframe (oldest first)
  double seconds = 0;             ///< wall time of the scoring, preparation included
  int prepared = 0;               ///< keyframes this call prepared (not prepared before)

  /// The mean over the keyframes of a criterion's scores (0 without keyframes).
  static double mean(const FrameScores& s, Criterion c) { return summarize(s[int(c)]).mean; }
  /// The estimate's advantage over the initial extrinsics, paired keyframe by keyframe and
  /// oriented so that positive is better (higherIsBetter).
  ScoreSummary advantage(Criterion c) const;
  /// "0.2310 (initial 0.2070: better, significant)": the means and the paired difference's
  /// verdict.
  std::string describe(Criterion c) const;
  /// Every criterion's describe(), "edge_alignment 0.2310 (initial ...), photometric_residual ...".
  std::string summary() const;
};

/// score() runs in one thread at a time (the node's solve thread); prepare() may run in another
/// (the node's keyframe thread) at the same time.
class WindowQuality {
 public:
  /// `initial`: the intrinsics and the initial extrinsics the estimates are compared with.
  /// `settings.stereo`: the keyframes' stereo settings, for their clouds triangulated with
  /// another left->right extrinsic.
  explicit WindowQuality(const StereoRig& initial, const ValidationSettings& settings = {});

  /// Prepares a keyframe and scores the initial extrinsics on it ahead of score() (which does
  /// so itself for a keyframe not prepared): the work that does not depend on the estimate, done
  /// where a keyframe is built rather than where the estimate waits for its scores.
  void prepare(const std::shared_ptr<const Keyframe>& keyframe);

  /// Scores (T_cam_lidar, T_right_left) and the initial extrinsics on `keyframes` (each with its
  /// grey images, scan and stereo cloud). Keyframes not passed are forgotten, unless prepared
  /// since the last call (a keyframe newer than the estimate's).
  WindowQualityScores score(const std::vector<std::shared_ptr<const Keyframe>>& keyframes,
                            const Eigen::Isometry3d& T_cam_lidar,
                            const Eigen::Isometry3d& T_right_left);

  /// Keyframes prepared and kept.
  size_t kept() const;

 private:
  struct Kept {
    std::shared_ptr<const PreparedFrame> prepared;
    /// The initial extrinsics' scores. They read the keyframe's SGBM matches, triangulated for
    /// the initial pair: valid while its matches are those made with `scored_matched` (a
    /// keyframe the window replaced with one matched again is scored again).
    std::array<double, kCriteria> initial{};
    bool scored = false;
    Eigen::Isometry3d scored_matched = Eigen::Isometry3d::Identity();
    bool fresh = false;  ///< prepared by prepare() since the last score()
  };
  /// The keyframe's stereo cloud for `T_right_left`: its own, or its matches triangulated again.
  std::shared_ptr<const StereoCloud> cloudFor(const std::shared_ptr<const Keyframe>& kf,
                                              const Eigen::Isometry3d& T_right_left) const;
  /// Prepares the keyframe and scores the initial extrinsics on it, where `k` lacks them.
  void complete(const std::shared_ptr<const Keyframe>& kf, Kept* k) const;

  StereoRig initial_;
  ValidationSettings settings_;
  mutable std::mutex mutex_;
  std::map<double, Kept> prepared_;  ///< GUARDED_BY(mutex_), by keyframe stamp
};

}  // namespace tescalib
