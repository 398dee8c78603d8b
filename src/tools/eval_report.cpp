#include "eval_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <numeric>
#include <sstream>
#include <utility>

#include "eval_json.h"

namespace tescalib::eval {

double median(std::vector<double> v) {
  // Not a number when any value is not one (std::sort has no order for NaN, and leaving it out
  // would hide a trial that has no error).
  if (v.empty() || std::any_of(v.begin(), v.end(), [](double x) { return std::isnan(x); }))
    return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

/// An extrinsic's block of a trial: its start, error and covariance (null where the mode does
/// not estimate it), and what the LiDAR-stereo solve adds.
Json extrinsicJson(const ExtrinsicOutcome& o) {
  double ir[3], it[3], er[3], et[3], sr[3], st[3], c[36];
  for (int i = 0; i < 3; ++i) {
    ir[i] = o.init[i] * kDegPerRad, it[i] = o.init[3 + i];
    er[i] = o.err[i] * kDegPerRad, et[i] = o.err[3 + i];
    sr[i] = std::sqrt(o.cov(i, i)) * kDegPerRad, st[i] = std::sqrt(o.cov(3 + i, 3 + i));
  }
  for (int i = 0; i < 36; ++i) c[i] = o.cov(i / 6, i % 6);
  if (!o.estimated) {
    std::fill(std::begin(c), std::end(c), std::nan(""));
    std::fill(std::begin(sr), std::end(sr), std::nan(""));
    std::fill(std::begin(st), std::end(st), std::nan(""));
  }
  Json j = {{"estimated", o.estimated},          {"init_rot_deg", jsonArray(ir, 3)},
            {"init_trans_m", jsonArray(it, 3)},  {"rot_err_deg", jsonArray(er, 3)},
            {"trans_err_m", jsonArray(et, 3)},   {"sigma_rot_deg", jsonArray(sr, 3)},
            {"sigma_trans_m", jsonArray(st, 3)}, {"covariance", jsonArray(c, 36)}};
  if (o.cov_stat.allFinite()) {
    for (int i = 0; i < 3; ++i)
      sr[i] = std::sqrt(o.cov_stat(i, i)) * kDegPerRad, st[i] = std::sqrt(o.cov_stat(3 + i, 3 + i));
    j["sigma_statistical_rot_deg"] = jsonArray(sr, 3);
    j["sigma_statistical_trans_m"] = jsonArray(st, 3);
    for (int i = 0; i < 36; ++i) c[i] = o.cov_stat(i / 6, i % 6);
    j["covariance_statistical"] = jsonArray(c, 36);
  }
  if (o.bias.allFinite()) {
    double b[6 * kLidarStereoBiases];
    for (int i = 0; i < 6 * kLidarStereoBiases; ++i) b[i] = o.bias(i % 6, i / 6);
    j["bias_sensitivity_disparity_px"] = jsonArray(b, 6);
    j["bias_sensitivity_range_m"] = jsonArray(b + 6, 6);
    j["bias_sensitivity_disparity_scale"] = jsonArray(b + 12, 6);
    j["bias_sensitivity_ground_disparity_px"] = jsonArray(b + 18, 6);
    j["bias_sensitivity_ground_tilt_px"] = jsonArray(b + 24, 6);
    j["bias_sensitivity_lateral_disparity_px"] = jsonArray(b + 30, 6);
    j["bias_sensitivity_lateral_tilt_px"] = jsonArray(b + 36, 6);
  }
  if (std::isfinite(o.fixed_point_contraction))
    j["fixed_point_contraction"] = o.fixed_point_contraction;
  return j;
}

/// The LiDAR-stereo split-window check over the trials that ran it.
void printSplitWindowCheck(const std::vector<Trial>& trials) {
  std::vector<double> chi2;
  int beyond = 0;
  for (const auto& tr : trials)
    if (tr.halves.tested) {
      chi2.push_back(tr.halves.chi2);
      beyond += tr.halves.covariance_scale > 1.0;
    }
  if (!chi2.empty())
    std::printf(
        "  split-window check: %zu of %zu trials tested, median chi2 %.1f (6 DoF), %d "
        "beyond the limit (covariance scaled)\n",
        chi2.size(), trials.size(), median(chi2), beyond);
}

/// The weakest direction of what each window constrains (LidarStereoResult::weakest,
/// PhotometricResult::weakest), and the one of the trial with the median ratio.
void printWeakestDirections(const std::vector<Trial>& trials) {
  for (const auto& [name, member] :
       {std::pair{"LiDAR", &Trial::lidar_weakest}, std::pair{"stereo", &Trial::stereo_weakest}}) {
    std::vector<const WeakDirection*> weak;
    int above = 0;
    for (const auto& tr : trials)
      if ((tr.*member).ratio > 0) {
        weak.push_back(&(tr.*member));
        above += (tr.*member).ratio > 1.0;
      }
    if (weak.empty()) continue;
    std::sort(weak.begin(), weak.end(),
              [](const WeakDirection* a, const WeakDirection* b) { return a->ratio < b->ratio; });
    std::printf(
        "  %s weakest direction (what the window constrains, in units of the trust limits): "
        "median %s; above the limit in %d of %zu trials\n",
        name, describeWeakest(*weak[weak.size() / 2]).c_str(), above, weak.size());
  }
}

/// The common disparity offset the LiDAR-stereo residuals show.
void printDisparityOffsets(const std::vector<Trial>& trials,
                           const LidarStereoSettings& solver_settings) {
  std::vector<double> offsets;
  int beyond = 0;
  for (const auto& tr : trials)
    if (std::isfinite(tr.disparity_offset_px)) {
      offsets.push_back(tr.disparity_offset_px);
      beyond += tr.disparity_offset_used;
    }
  if (!offsets.empty())
    std::printf(
        "  disparity offset the residuals show: median %+.3f px, %d of %zu trials determine "
        "one beyond the model's %.3f px (their bias term uses it)\n",
        median(offsets), beyond, offsets.size(), solver_settings.model_sigma_disparity_px);
}

/// stereo mode with --lidar-*: the LiDAR error applied and what is left after its estimate.
void printLidarNuisance(const std::vector<Trial>& trials) {
  // The LiDAR error nuisance: the error applied (--lidar-rot-deg / --lidar-trans-m) and what is
  // left of it after the correction the left-right solve found (perturb(T, found)).
  std::vector<double> rot_applied, trans_applied, rot_left, trans_left;
  for (const auto& tr : trials) {
    if (!std::isfinite(tr.lidar_error_found[0])) continue;
    const Vector6d left = poseError(
        perturb(perturb(Eigen::Isometry3d::Identity(), tr.lidar.init), tr.lidar_error_found),
        Eigen::Isometry3d::Identity());
    rot_applied.push_back(tr.lidar.init.head<3>().norm() * kDegPerRad);
    trans_applied.push_back(100 * tr.lidar.init.tail<3>().norm());
    rot_left.push_back(left.head<3>().norm() * kDegPerRad);
    trans_left.push_back(100 * left.tail<3>().norm());
  }
  if (!rot_left.empty())
    std::printf(
        "  LiDAR error nuisance: applied %.3f deg / %.2f cm, left after its estimate %.3f deg / "
        "%.2f cm (medians of %zu trials)\n",
        median(rot_applied), median(trans_applied), median(rot_left), median(trans_left),
        rot_left.size());
}

using Estimated = std::vector<std::pair<std::string, const ExtrinsicOutcome Trial::*>>;

/// The extrinsics the mode estimates; a trial succeeds when all of them do.
Estimated estimatedExtrinsics(const Args& args) {
  Estimated estimated;
  if (args.mode != "stereo") estimated.emplace_back("lidar", &Trial::lidar);
  if (args.mode != "lidar_stereo") estimated.emplace_back("stereo", &Trial::stereo);
  return estimated;
}

bool trialSuccess(const Estimated& estimated, const Trial& tr) {
  bool ok = true;
  for (const auto& e : estimated) ok = ok && (tr.*(e.second)).success();
  return ok;
}

/// `v` to 6 significant digits, the precision of the summary's per-extrinsic success rates (the
/// overall rate has 10, as every other number).
double sixDigits(double v) {
  std::ostringstream o;
  o << v;
  return std::stod(o.str());
}

/// One extrinsic's medians over the trials: errors per axis and of the norms, and the
/// statistical sigmas (what the windows constrain, without the model error).
struct ExtrinsicSummary {
  double med_rot[3], med_trans[3], stat_rot[3], stat_trans[3];
  double rot_norm, trans_norm, success;
};

ExtrinsicSummary summarize(const ExtrinsicOutcome Trial::*member,
                           const std::vector<Trial>& trials) {
  ExtrinsicSummary e;
  std::vector<double> rn, tn;
  int ok = 0;
  for (int i = 0; i < 3; ++i) {
    std::vector<double> r, tt, sr, st;
    for (const auto& tr : trials) {
      r.push_back(std::fabs((tr.*member).err[i]) * kDegPerRad);
      tt.push_back(std::fabs((tr.*member).err[3 + i]));
      const Matrix6d& c = (tr.*member).cov_stat;
      if (!c.allFinite()) continue;
      sr.push_back(std::sqrt(c(i, i)) * kDegPerRad);
      st.push_back(std::sqrt(c(3 + i, 3 + i)));
    }
    e.med_rot[i] = median(r);
    e.med_trans[i] = median(tt);
    e.stat_rot[i] = median(sr);
    e.stat_trans[i] = median(st);
  }
  for (const auto& tr : trials) {
    rn.push_back((tr.*member).err.head<3>().norm() * kDegPerRad);
    tn.push_back((tr.*member).err.tail<3>().norm());
    ok += (tr.*member).success();
  }
  e.rot_norm = median(rn);
  e.trans_norm = median(tn);
  e.success = double(ok) / trials.size();
  return e;
}

void printExtrinsicSummary(const std::string& name, const ExtrinsicSummary& e) {
  std::printf("  %s: success %.1f %%\n", name.c_str(), 100.0 * e.success);
  std::printf("    median |err| rot  [x y z] deg: %.4f %.4f %.4f   (median norm %.4f deg)\n",
              e.med_rot[0], e.med_rot[1], e.med_rot[2], e.rot_norm);
  std::printf("    median |err| trans [x y z] cm: %.3f %.3f %.3f   (median norm %.3f cm)\n",
              e.med_trans[0] * 100, e.med_trans[1] * 100, e.med_trans[2] * 100, e.trans_norm * 100);
  if (std::isfinite(e.stat_rot[0]))
    std::printf(
        "    median statistical sigma (what the window constrains) rot [x y z] deg: %.4f %.4f "
        "%.4f, trans cm: %.3f %.3f %.3f\n",
        e.stat_rot[0], e.stat_rot[1], e.stat_rot[2], e.stat_trans[0] * 100, e.stat_trans[1] * 100,
        e.stat_trans[2] * 100);
}

Json extrinsicSummaryJson(const ExtrinsicSummary& e) {
  Json j = {{"median_abs_rot_err_deg", jsonArray(e.med_rot, 3)},
            {"median_abs_trans_err_m", jsonArray(e.med_trans, 3)},
            {"success_rate", sixDigits(e.success)}};
  if (std::isfinite(e.stat_rot[0])) {
    j["median_sigma_statistical_rot_deg"] = jsonArray(e.stat_rot, 3);
    j["median_sigma_statistical_trans_m"] = jsonArray(e.stat_trans, 3);
  }
  j["median_rot_err_norm_deg"] = jsonNumber(e.rot_norm);
  j["median_trans_err_norm_m"] = jsonNumber(e.trans_norm);
  return j;
}

/// Prints each estimated extrinsic's success rate, median errors and statistical sigmas; returns
/// the summary's JSON members for both extrinsics ("lidar": {...}, "stereo": {...}).
Json printExtrinsicSummaries(const Estimated& estimated, const std::vector<Trial>& trials) {
  Json summary = Json::object();
  for (const auto& [name, member] : estimated) {
    const ExtrinsicSummary e = summarize(member, trials);
    printExtrinsicSummary(name, e);
    summary[name] = extrinsicSummaryJson(e);
  }
  // The extrinsic the mode does not estimate: named, so that both keys are always there.
  for (const char* name : {"lidar", "stereo"})
    if (!summary.contains(name)) summary[name] = {{"estimated", false}};
  return summary;
}

/// The solver's extra outputs of a trial, where it has them.
void addSolverOutputs(const Trial& tr, Json* js) {
  Json& j = *js;
  if (tr.rematches >= 0) j["rematches"] = tr.rematches;
  if (tr.yaw_handovers >= 0) j["yaw_handovers"] = tr.yaw_handovers;
  if (tr.lidar_first >= 0) j["lidar_first"] = tr.lidar_first != 0;
  if (tr.search_starts >= 0) j["search_starts"] = tr.search_starts;
  if (std::isfinite(tr.stereo_scale)) {
    j["stereo_scale"] = jsonNumber(tr.stereo_scale);
    j["stereo_scale_sigma"] = jsonNumber(tr.stereo_scale_sigma);
  }
  if (std::isfinite(tr.stereo_yaw_deg)) j["stereo_yaw_deg"] = jsonNumber(tr.stereo_yaw_deg);
  // null where not measured (doc/evaluation.md).
  j["disparity_offset_px"] = jsonNumber(tr.disparity_offset_px);
  j["disparity_offset_sigma_px"] = jsonNumber(tr.disparity_offset_sigma_px);
  j["disparity_offset_used"] =
      std::isfinite(tr.disparity_offset_px) ? Json(tr.disparity_offset_used) : Json(nullptr);
  if (std::isfinite(tr.lidar_error_found[0])) {
    double found[6];
    for (int i = 0; i < 6; ++i)
      found[i] = i < 3 ? tr.lidar_error_found[i] * kDegPerRad : tr.lidar_error_found[i];
    j["lidar_error_found"] = jsonArray(found, 6);
  }
  for (const auto& [key, w] : {std::pair{"lidar_weakest_direction", &tr.lidar_weakest},
                               std::pair{"stereo_weakest_direction", &tr.stereo_weakest}})
    if (w->ratio > 0)
      j[key] = {{"ratio", jsonNumber(w->ratio)},
                {"direction", jsonArray(w->direction.data(), 6)},
                {"in_words", describeDirection(w->direction)}};
  if (tr.halves.tested)
    j["halves"] = {{"chi2", jsonNumber(tr.halves.chi2)},
                   {"chi2_window", jsonNumber(tr.halves.chi2_window)},
                   {"chi2_independent", jsonNumber(tr.halves.chi2_independent)},
                   {"covariance_scale", jsonNumber(tr.halves.covariance_scale)},
                   {"seconds", jsonNumber(tr.halves.seconds)}};
}

/// One trial's object in the JSON's "trials" list.
Json trialJson(const Args& args, const Estimated& estimated, const Trial& tr) {
  Json j = {{"seed", tr.seed},
            {"window_index", tr.window_index},
            {"converged", tr.converged},
            {"success", trialSuccess(estimated, tr)},
            {"lidar", extrinsicJson(tr.lidar)},
            {"stereo", extrinsicJson(tr.stereo)}};
  if (args.mode != "lidar_stereo") {  // the photometric solves' brightness per keyframe
    j["brightness"] = Json::array();
    for (const auto& b : tr.brightness) j["brightness"].push_back(jsonArray(b.data(), 2));
  }
  j["nees"] = jsonNumber(tr.nees);
  j["nees_model"] = jsonNumber(tr.nees_model);
  j["iterations"] = tr.iterations;
  j["message"] = tr.message;
  addSolverOutputs(tr, &j);
  Json seconds = {{"preprocess", jsonNumber(tr.preprocess)},
                  {"solve", jsonNumber(tr.solve)},
                  {"total", jsonNumber(tr.preprocess + tr.solve)}};
  for (const auto& [stage, sec] : tr.stage_seconds) seconds[stage] = jsonNumber(sec);
  j["seconds"] = seconds;
  return j;
}

/// The run's totals over the trials.
struct Totals {
  std::vector<double> pre, sol, nees, nees_model, nees_converged;
  int ok_all = 0, converged_all = 0;
  double mean_nees = std::nan(""), mean_nees_converged = std::nan("");
  double mean_nees_model = std::nan("");
};

Totals totals(const Estimated& estimated, const std::vector<Trial>& trials) {
  Totals t;
  for (const auto& tr : trials) {
    t.pre.push_back(tr.preprocess);
    t.sol.push_back(tr.solve);
    if (std::isfinite(tr.nees)) t.nees.push_back(tr.nees);
    if (std::isfinite(tr.nees) && tr.converged) t.nees_converged.push_back(tr.nees);
    if (std::isfinite(tr.nees_model)) t.nees_model.push_back(tr.nees_model);
    t.ok_all += trialSuccess(estimated, tr);
    t.converged_all += tr.converged;
  }
  if (!t.nees_model.empty()) {
    t.mean_nees_model = 0;
    for (double v : t.nees_model) t.mean_nees_model += v / t.nees_model.size();
  }
  auto mean = [](const std::vector<double>& v) {
    double m = std::nan("");
    if (!v.empty()) m = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    return m;
  };
  t.mean_nees = mean(t.nees);
  // Over the trials the estimator declared converged: the estimates an online node publishes.
  t.mean_nees_converged = mean(t.nees_converged);
  return t;
}

/// The NEES lines of the summary.
void printNees(const Totals& t, size_t n_trials) {
  if (std::isfinite(t.mean_nees)) {
    std::printf("  mean NEES (6 DoF, ideal 6): %.2f", t.mean_nees);
    if (t.nees.size() < n_trials)  // the others have no covariance (covariance_known)
      std::printf(" (over the %zu of %zu trials with a covariance)", t.nees.size(), n_trials);
    std::printf("\n");
  }
  if (std::isfinite(t.mean_nees_converged))
    std::printf("  mean NEES of the %zu converged trials: %.2f\n", t.nees_converged.size(),
                t.mean_nees_converged);
  if (std::isfinite(t.mean_nees_model))
    std::printf("  mean NEES with the paper's covariance alone (eq. residual_uncertainty): %.2f\n",
                t.mean_nees_model);
}

/// The whole JSON: the run's settings, the trials and the summary.
Json runJson(const Args& args, const EvalData& d, const Estimated& estimated,
             const std::vector<Trial>& trials, const Totals& t, Json summary) {
  Json j = {{"mode", args.mode},
            {"method", args.method},
            {"window", d.window_size},
            {"windows", d.n_windows},
            {"seed", args.seed},
            {"init_rot_deg", args.init_rot_deg},
            {"init_trans_m", args.init_trans_m},
            {"init_stereo_rot_deg", args.init_stereo_rot_deg},
            {"init_stereo_trans_m", args.init_stereo_trans_m},
            {"refinement",
             {{"iterations", d.used_refinement.iterations},
              {"smoothed_rounds", d.used_refinement.smoothed_gradient_rounds}}},
            {"sgbm_paths", args.sgbm_paths},
            {"sgbm_both_ways", args.sgbm_both_ways},
            {"rectified_vertical_blur_px", d.kfs.stereo.rectified_vertical_blur_px},
            {"consistent_sample", args.consistent_sample},
            {"trials", Json::array()}};
  for (const auto& tr : trials) j["trials"].push_back(trialJson(args, estimated, tr));
  summary["success_rate"] = double(t.ok_all) / trials.size();
  summary["declared_converged_rate"] = double(t.converged_all) / trials.size();
  summary["mean_nees"] = jsonNumber(t.mean_nees);
  summary["mean_nees_converged"] = jsonNumber(t.mean_nees_converged);
  summary["mean_nees_model"] = jsonNumber(t.mean_nees_model);
  summary["seconds"] = {{"preprocess", jsonNumber(median(t.pre))},
                        {"solve", jsonNumber(median(t.sol))}};
  j["summary"] = std::move(summary);
  return j;
}

}  // namespace

bool report(const Args& args, const EvalData& d, const LidarStereoSettings& solver_settings,
            const std::vector<Trial>& trials) {
  const Estimated estimated = estimatedExtrinsics(args);
  const Totals t = totals(estimated, trials);
  std::printf("\nsummary (%s, %s, %zu window(s) of %zu, %zu trials)\n", args.mode.c_str(),
              args.method.c_str(), d.n_windows, d.window_size, trials.size());
  std::printf("  success rate (< 0.2 deg and < 3 cm%s): %.1f %%; declared converged: %d of %zu\n",
              estimated.size() > 1 ? ", both extrinsics" : "", 100.0 * t.ok_all / trials.size(),
              t.converged_all, trials.size());
  Json summary = printExtrinsicSummaries(estimated, trials);
  std::printf(
      "  time per window: preprocess %.2f s (stereo %.2f s, %zu keyframes), solve median %.2f s\n",
      median(t.pre), d.stereo_seconds / d.n_windows, d.window_size, median(t.sol));
  printNees(t, trials.size());
  printSplitWindowCheck(trials);
  printWeakestDirections(trials);
  printDisparityOffsets(trials, solver_settings);
  printLidarNuisance(trials);
  if (args.json.empty()) return true;
  std::ofstream js(args.json);
  if (!js) {
    std::cerr << "tescalib_eval: cannot write " << args.json << "\n";
    return false;
  }
  writeJson(js, runJson(args, d, estimated, trials, t, std::move(summary)));
  js << "\n";
  std::cout << "wrote " << args.json << "\n";
  return true;
}

}  // namespace tescalib::eval
