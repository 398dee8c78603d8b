#include "validate_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "tescalib/core/common/geometry.h"

namespace tescalib::validate {
namespace {

const char* const kAxes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};

std::string format(const char* fmt, double a) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), fmt, a);
  return buf;
}

/// "%-22s" padded cell.
std::string cell(const std::string& s, size_t width) {
  return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}

/// The pose difference of T against the reference: "0.123 deg / 4.56 cm".
std::string poseDifference(const Eigen::Isometry3d& T, const Eigen::Isometry3d& reference) {
  const Vector6d e = poseError(T, reference);
  return format("%.3f deg / ", e.head<3>().norm() * kDegPerRad) +
         format("%.2f cm", e.tail<3>().norm() * 100);
}

/// The score, and for all but the best its difference to the best with the standard error of the
/// frame-by-frame differences, * when significant.
std::string scoreCell(const std::vector<Scored>& all, size_t row, Criterion c) {
  const int i = static_cast<int>(c);
  const size_t best = bestOf(all, c);
  std::string s = format("%.4f", all[row].validation.criteria[i].score.mean);
  if (row == best) return s + " (best)";
  const ScoreSummary d =
      pairedDifference(all[row].validation.frames[i], all[best].validation.frames[i]);
  return s + format(" (%+.4f", d.mean) + format(" +- %.4f", d.standard_error) +
         (significant(d) ? " *)" : ")");
}

std::string directionLine(const CriterionValidation& v, const ValidationSettings& settings) {
  std::string s;
  for (int k = 0; k < 6; ++k)
    s += std::string(" ") + kAxes[k] + (v.direction[k] > 0 ? "+" : v.direction[k] < 0 ? "-" : ".");
  s += "   sensitivity per " + format("%g deg", settings.step_rot_deg) + " / " +
       format("%g cm:", settings.step_trans_m * 100);
  for (int k = 0; k < 6; ++k) s += format(" %.4f", v.sensitivity(k)) + (v.sees[k] ? "" : "?");
  return s;
}

/// The per-axis error of T against the reference: " rx ry rz" deg, " tx ty tz" cm.
std::string axisErrors(const Eigen::Isometry3d& T, const Eigen::Isometry3d& reference) {
  const Vector6d e = poseError(T, reference);
  std::string s;
  for (int k = 0; k < 3; ++k) s += format(" %.3f", e(k) * kDegPerRad);
  for (int k = 3; k < 6; ++k) s += format(" %.2f", e(k) * 100);
  return s;
}

/// Where the criterion's optimum lies and how much better it scores than the calibration.
std::string optimumLine(const Scored& s, int i) {
  const Criterion c = kAllCriteria[i];
  ScoreSummary d = pairedDifference(s.optimum_scores[i], s.validation.frames[i]);
  if (!higherIsBetter(c)) d.mean = -d.mean;
  return "    its optimum: " + poseDifference(s.optima[i], s.T_cam_lidar) + " away, error [" +
         axisErrors(s.optima[i], s.T_cam_lidar) + " ] deg, cm; " +
         (s.optima_held_out ? std::string("on these frames, held out from its search, it scores ")
                            : std::string("on these frames, where it was searched, it scores ")) +
         format("better by %.4f", d.mean) + format(" +- %.4f", d.standard_error) +
         (significant(d) ? " (significant)\n" : " (not significant)\n");
}

/// The two-sided 95 % quantile of chi2 with 1..6 degrees of freedom.
double chi2Quantile95(int dof) {
  constexpr double q[7] = {0, 3.84, 5.99, 7.81, 9.49, 11.07, 12.59};
  return q[std::max(0, std::min(dof, 6))];
}

/// The optimum's 1-sigma uncertainty per axis and where the calibration lies in it.
std::string uncertaintyLine(const Scored& s, int i) {
  const OptimumUncertainty& u = s.optimum_uncertainty[i];
  std::string out = format("    its 1-sigma uncertainty (%.0f frames): [", u.frames);
  for (int k = 0; k < 6; ++k) {
    const double scale = k < 3 ? kDegPerRad : 100.0;
    out +=
        u.resolved[k] ? format(k < 3 ? " %.3f" : " %.2f", u.sigma(k) * scale) : std::string(" -");
  }
  out += " ] deg, cm (-: not resolved)";
  if (u.rank == 0) return out + "\n";
  const double chi2 = u.chi2(s.optima[i], s.T_cam_lidar);
  return out + format("; the calibration lies at chi2 %.1f", chi2) +
         format(" (%.0f DoF) from it", u.rank) +
         (chi2 > chi2Quantile95(u.rank) ? " (outside its 95 %)\n" : " (within its 95 %)\n");
}

nlohmann::json vec6(const Vector6d& v) {
  return nlohmann::json::array({v(0), v(1), v(2), v(3), v(4), v(5)});
}

nlohmann::json poseJson(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  return {{"translation", {t.x(), t.y(), t.z()}},
          {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}};
}

nlohmann::json differenceJson(const Eigen::Isometry3d& T, const Eigen::Isometry3d& reference) {
  const Vector6d e = poseError(T, reference);
  return {{"rotation_deg", e.head<3>().norm() * kDegPerRad},
          {"translation_m", e.tail<3>().norm()},
          {"error", vec6(e)}};
}

/// The optimum's covariance [rad, m] (over its resolved directions), sigma per axis (null where
/// not resolved), and the calibration's and the recording's chi2 against it.
nlohmann::json uncertaintyJson(const Scored& s, int i, const Eigen::Isometry3d& T_recording) {
  const OptimumUncertainty& u = s.optimum_uncertainty[i];
  nlohmann::json sigma = nlohmann::json::array(), cov = nlohmann::json::array();
  for (int k = 0; k < 6; ++k)
    sigma.push_back(u.resolved[k] ? nlohmann::json(u.sigma(k)) : nlohmann::json());
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) cov.push_back(u.covariance(r, c));
  return {{"frames", u.frames},
          {"resolved", u.resolved},
          {"rank", u.rank},
          {"sigma", sigma},
          {"covariance", cov},
          {"calibration_chi2", u.rank > 0 ? u.chi2(s.optima[i], s.T_cam_lidar) : 0.0},
          {"recording_chi2", u.rank > 0 ? u.chi2(s.optima[i], T_recording) : 0.0}};
}

nlohmann::json calibrationJson(const std::vector<Scored>& all, size_t row) {
  const Scored& s = all[row];
  nlohmann::json j = {
      {"name", s.name},
      {"source", s.source},
      {"T_cam_lidar", poseJson(s.T_cam_lidar)},
      {"T_right_left", poseJson(s.T_right_left)},
      {"difference_to_recording", differenceJson(s.T_cam_lidar, all[0].T_cam_lidar)}};
  for (Criterion c : kAllCriteria) {
    const std::string n = criterionName(c);
    const CriterionValidation& v = s.validation.criteria[static_cast<int>(c)];
    const size_t best = bestOf(all, c);
    const ScoreSummary d = pairedDifference(s.validation.frames[static_cast<int>(c)],
                                            all[best].validation.frames[static_cast<int>(c)]);
    j["scores"][n] = v.score.mean;
    j["standard_errors"][n] = v.score.standard_error;
    j["frame_scores"][n] = s.validation.frames[static_cast<int>(c)];
    j["difference_to_best"][n] = {{"best", all[best].name},
                                  {"difference", d.mean},
                                  {"standard_error", d.standard_error},
                                  {"significant", row != best && significant(d)}};
    if (s.perturbed) continue;
    j["sensitivity"][n] = vec6(v.sensitivity);
    j["gradient"][n] = vec6(v.gradient);
    j["gradient_standard_error"][n] = vec6(v.gradient_se);
    j["direction"][n] = v.direction;
    j["sees"][n] = v.sees;
    if (s.has_optima)
      j["optimum"][n] = {
          {"T_cam_lidar", poseJson(s.optima[static_cast<int>(c)])},
          {"difference", differenceJson(s.optima[static_cast<int>(c)], s.T_cam_lidar)},
          {"score", summarize(s.optimum_scores[static_cast<int>(c)]).mean},
          {"frame_scores", s.optimum_scores[static_cast<int>(c)]},
          {"uncertainty", uncertaintyJson(s, static_cast<int>(c), all[0].T_cam_lidar)}};
  }
  return j;
}

}  // namespace

size_t bestOf(const std::vector<Scored>& all, Criterion c) {
  const int i = static_cast<int>(c);
  size_t best = 0;
  for (size_t r = 1; r < all.size(); ++r) {
    const double a = all[r].validation.criteria[i].score.mean;
    const double b = all[best].validation.criteria[i].score.mean;
    if (higherIsBetter(c) ? a > b : a < b) best = r;
  }
  return best;
}

std::string scoreTable(const std::vector<Scored>& all, const ValidationSettings& settings) {
  const size_t w0 = 14, w = 40;
  std::string out = cell("calibration", w0);
  for (Criterion c : kAllCriteria)
    out += cell(std::string(criterionName(c)) + (higherIsBetter(c) ? " (higher" : " (lower") +
                    " is better)",
                w);
  out += "\n";
  for (size_t r = 0; r < all.size(); ++r) {
    out += cell(all[r].name, w0);
    for (Criterion c : kAllCriteria) out += cell(scoreCell(all, r, c), w);
    out += "\n";
  }
  out += "(difference to the best +- its standard error over the frames; * significant at 95 %)\n";
  for (size_t r = 0; r < all.size(); ++r) {
    if (all[r].perturbed) continue;
    out += "\n" + all[r].name + " (" + all[r].source + ")";
    if (r > 0)
      out += ", " + poseDifference(all[r].T_cam_lidar, all[0].T_cam_lidar) + " from recording";
    out += "\n  along which axes each criterion would move it (+ / -; . not significantly):\n";
    for (Criterion c : kAllCriteria) {
      const int i = static_cast<int>(c);
      out += "  " + cell(criterionName(c), 22) +
             directionLine(all[r].validation.criteria[i], settings) + "\n";
      if (all[r].has_optima) out += optimumLine(all[r], i) + uncertaintyLine(all[r], i);
    }
  }
  out +=
      "(sensitivity: the score's mean change for a step either way; ? where it is not "
      "significant)\n";
  return out;
}

nlohmann::json validationJson(const std::vector<Scored>& all, const ValidationSettings& settings,
                              const std::vector<std::string>& frames) {
  nlohmann::json j;
  j["frames"] = frames;
  j["step"] = {{"rot_deg", settings.step_rot_deg}, {"trans_m", settings.step_trans_m}};
  j["axes"] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  for (Criterion c : kAllCriteria) {
    j["higher_is_better"][criterionName(c)] = higherIsBetter(c);
    j["units"][criterionName(c)] = criterionUnit(c);
  }
  j["calibrations"] = nlohmann::json::array();
  for (size_t r = 0; r < all.size(); ++r) j["calibrations"].push_back(calibrationJson(all, r));
  return j;
}

}  // namespace tescalib::validate
