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

void WindowQuality::complete(const std::shared_ptr<const Keyframe>& kf, Kept* k) const {
  if (!k->prepared)
    k->prepared = std::make_shared<const PreparedFrame>(
        prepareFrame(kf->left_gray, kf->right_gray, kf->scan, settings_));
  if (k->scored && sameExtrinsic(k->scored_matched, kf->T_right_left_matched)) return;
  const std::shared_ptr<const StereoCloud> cloud = cloudFor(kf, initial_.T_right_left);
  for (Criterion c : kAllCriteria)
    k->initial[static_cast<int>(c)] =
        preparedFrameScore(*k->prepared, kf->scan, *cloud, c, initial_, initial_.T_cam_lidar,
                           initial_.T_right_left, settings_);
  k->scored = true;
  k->scored_matched = kf->T_right_left_matched;
}

void WindowQuality::prepare(const std::shared_ptr<const Keyframe>& keyframe) {
  Kept k;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = prepared_.find(keyframe->stamp);
    if (it != prepared_.end()) k = it->second;
  }
  if (k.prepared && k.scored && sameExtrinsic(k.scored_matched, keyframe->T_right_left_matched))
    return;
  complete(keyframe, &k);
  k.fresh = true;
  std::lock_guard<std::mutex> lock(mutex_);
  prepared_[keyframe->stamp] = k;
}

size_t WindowQuality::kept() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return prepared_.size();
}

WindowQualityScores WindowQuality::score(
    const std::vector<std::shared_ptr<const Keyframe>>& keyframes,
    const Eigen::Isometry3d& T_cam_lidar, const Eigen::Isometry3d& T_right_left) {
  const auto t0 = std::chrono::steady_clock::now();
  WindowQualityScores out;
  const int n = static_cast<int>(keyframes.size());
  out.keyframes = n;
  std::vector<Kept> use(n);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::set<double> stamps;
    for (const auto& kf : keyframes) stamps.insert(kf->stamp);
    for (auto it = prepared_.begin(); it != prepared_.end();) {
      const bool keep = stamps.count(it->first) || it->second.fresh;
      it->second.fresh = false;
      it = keep ? std::next(it) : prepared_.erase(it);
    }
    for (int i = 0; i < n; ++i) {
      const auto it = prepared_.find(keyframes[i]->stamp);
      if (it != prepared_.end()) use[i] = it->second;
      out.prepared += !use[i].prepared;
    }
  }
  // One keyframe per core, each writing only its own entries.
  std::vector<std::array<double, kCriteria>> estimate(n);
  parallelFor(n, resolveThreads(settings_.threads), [&](int i) {
    const std::shared_ptr<const Keyframe>& kf = keyframes[i];
    complete(kf, &use[i]);
    const std::shared_ptr<const StereoCloud> cloud = cloudFor(kf, T_right_left);
    for (Criterion c : kAllCriteria)
      estimate[i][static_cast<int>(c)] = preparedFrameScore(
          *use[i].prepared, kf->scan, *cloud, c, initial_, T_cam_lidar, T_right_left, settings_);
  });
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int i = 0; i < n; ++i) prepared_[keyframes[i]->stamp] = use[i];
  }
  for (Criterion c : kAllCriteria) {
    const int k = static_cast<int>(c);
    for (int i = 0; i < n; ++i) {
      out.estimate[k].push_back(estimate[i][k]);
      out.initial[k].push_back(use[i].initial[k]);
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace tescalib
