#include "calibrate_holdout.h"

#include <cstdio>

#include "tescalib/core/common/error.h"
#include "tescalib/core/validation/validation.h"

namespace tescalib::calibrate {
namespace {

/// "+0.0240 +- 0.0050 (better, significant)" for a - b of a criterion, paired frame by frame.
std::string verdict(const ScoreSummary& d, Criterion c) {
  const bool better = higherIsBetter(c) ? d.mean > 0 : d.mean < 0;
  char buf[128];
  std::snprintf(buf, sizeof buf, "%+.4f +- %.4f (%s, %s)", d.mean, d.standard_error,
                d.mean == 0 ? "the same"
                : better    ? "better"
                            : "worse",
                significant(d) ? "significant" : "not significant");
  return buf;
}

std::string yamlDifference(const ScoreSummary& d) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "{difference: %.6g, standard_error: %.6g, significant: %s}",
                d.mean, d.standard_error, significant(d) ? "true" : "false");
  return buf;
}

}  // namespace

std::string printHeldOut(const std::vector<Frame>& frames, int every, const StereoRig& rig,
                         const std::vector<HeldOutCalibration>& calibrations) {
  if (frames.empty() || calibrations.empty()) return "";
  std::vector<FrameScores> scores;
  try {
    ValidationSet set(frames, rig);
    for (const HeldOutCalibration& c : calibrations)
      scores.push_back(set.score(c.T_cam_lidar, c.T_right_left));
  } catch (const DataError& e) {
    std::printf("held-out scores: not computed (%s)\n", e.what());
    return "";
  }
  std::printf("held-out scores on %zu keyframes (1 in %d, not calibrated on; doc/validation.md):\n",
              frames.size(), every);
  char buf[256];
  std::snprintf(buf, sizeof buf, "  held_out:\n    keyframes: %zu\n    every: %d\n", frames.size(),
                every);
  std::string yaml = buf;
  const std::string& first = calibrations.front().name;
  for (Criterion c : kAllCriteria) {
    const int i = static_cast<int>(c);
    std::printf("  %s (%s is better):", criterionName(c), higherIsBetter(c) ? "higher" : "lower");
    yaml += std::string("    ") + criterionName(c) + ": {";
    for (size_t k = 0; k < calibrations.size(); ++k) {
      const double mean = summarize(scores[k][i]).mean;
      std::printf("%s %s %.4f", k ? "," : "", calibrations[k].name.c_str(), mean);
      std::snprintf(buf, sizeof buf, "%s: %.6g, ", calibrations[k].name.c_str(), mean);
      yaml += buf;
    }
    std::printf("\n");
    yaml += std::string("higher_is_better: ") + (higherIsBetter(c) ? "true" : "false");
    for (size_t k = 1; k < calibrations.size(); ++k) {
      const ScoreSummary d = pairedDifference(scores[0][i], scores[k][i]);
      std::printf("    %s - %s: %s\n", first.c_str(), calibrations[k].name.c_str(),
                  verdict(d, c).c_str());
      yaml += ", " + first + "_vs_" + calibrations[k].name + ": " + yamlDifference(d);
    }
    yaml += "}\n";
  }
  return yaml;
}

}  // namespace tescalib::calibrate
