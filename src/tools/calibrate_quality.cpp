#include "calibrate_quality.h"

#include <cstdio>
#include <fstream>

#include "tescalib/core/common/error.h"
#include "tescalib/core/validation/validation.h"

namespace tescalib::calibrate {

std::string printQuality(const std::vector<Frame>& keyframes, const StereoRig& initial,
                         const Eigen::Isometry3d& T_cam_lidar,
                         const Eigen::Isometry3d& T_right_left) {
  if (keyframes.empty()) return "";
  FrameScores est, init;
  try {
    ValidationSet set(keyframes, initial);
    est = set.score(T_cam_lidar, T_right_left);
    init = set.score(initial.T_cam_lidar, initial.T_right_left);
  } catch (const DataError& e) {
    std::printf("quality scores: not computed (%s)\n", e.what());
    return "";
  }
  std::printf(
      "quality scores on the last %zu keyframes (doc/validation.md), estimate vs initial "
      "guess:\n",
      keyframes.size());
  char buf[512];
  std::snprintf(buf, sizeof(buf), "quality:\n  keyframes: %zu\n", keyframes.size());
  std::string yaml = buf;
  for (Criterion c : kAllCriteria) {
    const int i = static_cast<int>(c);
    const ScoreSummary d = pairedDifference(est[i], init[i]);
    const bool better = higherIsBetter(c) ? d.mean > 0 : d.mean < 0;
    const double e = summarize(est[i]).mean, g = summarize(init[i]).mean;
    std::printf("  %-21s %.4f vs %.4f for the initial guess (%+.4f +- %.4f, %s, %s)\n",
                criterionName(c), e, g, d.mean, d.standard_error, better ? "better" : "worse",
                significant(d) ? "significant" : "not significant");
    std::snprintf(buf, sizeof(buf),
                  "  %s: {estimate: %.6g, initial_guess: %.6g, difference: %.6g, "
                  "standard_error: %.6g, significant: %s, higher_is_better: %s}\n",
                  criterionName(c), e, g, d.mean, d.standard_error,
                  significant(d) ? "true" : "false", higherIsBetter(c) ? "true" : "false");
    yaml += buf;
  }
  return yaml;
}

bool appendToResultYaml(const std::string& base, const std::string& block) {
  std::string path = base;
  if (path.size() > 5 && path.compare(path.size() - 5, 5, ".yaml") == 0)
    path.resize(path.size() - 5);
  std::ofstream out(path + ".yaml", std::ios::app);
  out << block;
  return static_cast<bool>(out);
}

}  // namespace tescalib::calibrate
