#include "tescalib/core/validation/window_quality.h"

#include <chrono>
#include <cstdio>
#include <set>

#include "tescalib/core/common/parallel.h"

namespace tescalib {
namespace {

bool sameExtrinsic(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return a.isApprox(b, 1e-12);
}

}  // namespace

ScoreSummary WindowQualityScores::advantage(Criterion c) const {
  const int i = static_cast<int>(c);
  return higherIsBetter(c) ? pairedDifference(estimate[i], initial[i])
                           : pairedDifference(initial[i], estimate[i]);
}

std::string WindowQualityScores::describe(Criterion c) const {
  const ScoreSummary a = advantage(c);
  char buf[160];
  std::snprintf(buf, sizeof buf, "%.4f (initial %.4f: %s, %s)", mean(estimate, c), mean(initial, c),
                a.mean > 0   ? "better"
                : a.mean < 0 ? "worse"
                             : "the same",
                significant(a) ? "significant" : "not significant");
  return buf;
}

std::string WindowQualityScores::summary() const {
  std::string out;
  for (Criterion c : kAllCriteria)
    out += (out.empty() ? "" : ", ") + std::string(criterionName(c)) + " " + describe(c);
  return out;
}

WindowQuality::WindowQuality(const StereoRig& initial, const ValidationSettings& settings)
    : initial_(initial), settings_(settings) {}

std::shared_ptr<const StereoCloud> WindowQuality::cloudFor(
    const std::shared_ptr<const Keyframe>& kf, const Eigen::Isometry3d& T_right_left) const {
  if (sameExtrinsic(kf->T_right_left_used, T_right_left))
    return std::shared_ptr<const StereoCloud>(kf, &kf->stereo);
  if (kf->stereo_matched.disparity.empty())  // no matches kept: the keyframe's cloud as it is
    return std::shared_ptr<const StereoCloud>(kf, &kf->stereo);
  return std::make_shared<const StereoCloud>(
      retriangulateStereoCloud(kf->stereo_matched, initial_, T_right_left, settings_.stereo));
}

void WindowQuality::scoreKeyframe(const std::shared_ptr<const Keyframe>& kf,
                                  const Eigen::Isometry3d& T_cam_lidar,
                                  const Eigen::Isometry3d& T_right_left, Kept* k,
                                  std::array<double, kCriteria>* estimate) const {
  if (!k->prepared)
    k->prepared = std::make_shared<const PreparedFrame>(
        prepareFrame(kf->left_gray, kf->right_gray, kf->scan, settings_));
  const std::shared_ptr<const StereoCloud> cloud = cloudFor(kf, T_right_left);
  for (Criterion c : kAllCriteria)
    (*estimate)[static_cast<int>(c)] = preparedFrameScore(
        *k->prepared, kf->scan, *cloud, c, initial_, T_cam_lidar, T_right_left, settings_);
  if (k->scored.lock() == kf) return;
  const std::shared_ptr<const StereoCloud> initial_cloud = cloudFor(kf, initial_.T_right_left);
  for (Criterion c : kAllCriteria)
    k->initial[static_cast<int>(c)] =
        preparedFrameScore(*k->prepared, kf->scan, *initial_cloud, c, initial_,
                           initial_.T_cam_lidar, initial_.T_right_left, settings_);
  k->scored = kf;
}

WindowQualityScores WindowQuality::score(
    const std::vector<std::shared_ptr<const Keyframe>>& keyframes,
    const Eigen::Isometry3d& T_cam_lidar, const Eigen::Isometry3d& T_right_left) {
  const auto t0 = std::chrono::steady_clock::now();
  WindowQualityScores out;
  const int n = static_cast<int>(keyframes.size());
  out.keyframes = n;
  std::set<double> stamps;
  for (const auto& kf : keyframes) stamps.insert(kf->stamp);
  for (auto it = prepared_.begin(); it != prepared_.end();)
    it = stamps.count(it->first) ? std::next(it) : prepared_.erase(it);
  // One keyframe per core, each writing only its own entries.
  std::vector<Kept*> kept(n);
  for (int i = 0; i < n; ++i) {
    kept[i] = &prepared_[keyframes[i]->stamp];
    out.prepared += !kept[i]->prepared;
  }
  std::vector<std::array<double, kCriteria>> estimate(n);
  parallelFor(n, resolveThreads(settings_.threads), [&](int i) {
    scoreKeyframe(keyframes[i], T_cam_lidar, T_right_left, kept[i], &estimate[i]);
  });
  for (Criterion c : kAllCriteria) {
    const int k = static_cast<int>(c);
    for (int i = 0; i < n; ++i) {
      out.estimate[k].push_back(estimate[i][k]);
      out.initial[k].push_back(kept[i]->initial[k]);
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace tescalib
