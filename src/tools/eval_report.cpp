#include "eval_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numeric>
#include <sstream>

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

std::string jsonArray(const double* v, int n) {
  std::ostringstream o;
  o << std::setprecision(10) << "[";
  // Not-a-number (no covariance: a baseline without one, an extrinsic the mode does not
  // estimate) is JSON's null, never 0 (which would read as exact).
  for (int i = 0; i < n; ++i) {
    o << (i ? ", " : "");
    if (std::isfinite(v[i]))
      o << v[i];
    else
      o << "null";
  }
  o << "]";
  return o.str();
}

/// A number, or null when there is none (not a number).
std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o << std::setprecision(10) << v;
  return o.str();
}

std::string ExtrinsicOutcome::json() const {
  double ir[3], it[3], er[3], et[3], sr[3], st[3], c[36];
  for (int i = 0; i < 3; ++i) {
    ir[i] = init[i] * kDegPerRad, it[i] = init[3 + i];
    er[i] = err[i] * kDegPerRad, et[i] = err[3 + i];
    sr[i] = std::sqrt(cov(i, i)) * kDegPerRad, st[i] = std::sqrt(cov(3 + i, 3 + i));
  }
  for (int i = 0; i < 36; ++i) c[i] = cov(i / 6, i % 6);
  if (!estimated) {
    std::fill(std::begin(c), std::end(c), std::nan(""));
    std::fill(std::begin(sr), std::end(sr), std::nan(""));
    std::fill(std::begin(st), std::end(st), std::nan(""));
  }
  std::ostringstream o;
  o << "{\"estimated\": " << (estimated ? "true" : "false")
    << ", \"init_rot_deg\": " << jsonArray(ir, 3) << ", \"init_trans_m\": " << jsonArray(it, 3)
    << ", \"rot_err_deg\": " << jsonArray(er, 3) << ", \"trans_err_m\": " << jsonArray(et, 3)
    << ", \"sigma_rot_deg\": " << jsonArray(sr, 3) << ", \"sigma_trans_m\": " << jsonArray(st, 3)
    << ", \"covariance\": " << jsonArray(c, 36);
  if (cov_stat.allFinite()) {
    for (int i = 0; i < 3; ++i)
      sr[i] = std::sqrt(cov_stat(i, i)) * kDegPerRad, st[i] = std::sqrt(cov_stat(3 + i, 3 + i));
    o << ", \"sigma_statistical_rot_deg\": " << jsonArray(sr, 3)
      << ", \"sigma_statistical_trans_m\": " << jsonArray(st, 3);
    for (int i = 0; i < 36; ++i) c[i] = cov_stat(i / 6, i % 6);
    o << ", \"covariance_statistical\": " << jsonArray(c, 36);
  }
  if (bias.allFinite()) {
    double b[12];
    for (int i = 0; i < 12; ++i) b[i] = bias(i % 6, i / 6);
    o << ", \"bias_sensitivity_disparity_px\": " << jsonArray(b, 6)
      << ", \"bias_sensitivity_range_m\": " << jsonArray(b + 6, 6);
  }
  o << "}";
  return o.str();
}

namespace {

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

/// Prints each estimated extrinsic's success rate, median errors and statistical sigmas; returns
/// the summary's JSON members for both extrinsics ("lidar": {...}, "stereo": {...}, ).
std::string printExtrinsicSummaries(const Estimated& estimated, const std::vector<Trial>& trials) {
  std::ostringstream summary_json;
  for (const auto& [name, member] : estimated) {
    double med_rot[3], med_trans[3];
    // What the windows constrain: the median statistical sigma per axis (no model error).
    double stat_rot[3], stat_trans[3];
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
      med_rot[i] = median(r);
      med_trans[i] = median(tt);
      stat_rot[i] = median(sr);
      stat_trans[i] = median(st);
    }
    for (const auto& tr : trials) {
      rn.push_back((tr.*member).err.head<3>().norm() * kDegPerRad);
      tn.push_back((tr.*member).err.tail<3>().norm());
      ok += (tr.*member).success();
    }
    const double success = double(ok) / trials.size();
    std::printf("  %s: success %.1f %%\n", name.c_str(), 100.0 * success);
    std::printf("    median |err| rot  [x y z] deg: %.4f %.4f %.4f   (median norm %.4f deg)\n",
                med_rot[0], med_rot[1], med_rot[2], median(rn));
    std::printf("    median |err| trans [x y z] cm: %.3f %.3f %.3f   (median norm %.3f cm)\n",
                med_trans[0] * 100, med_trans[1] * 100, med_trans[2] * 100, median(tn) * 100);
    if (std::isfinite(stat_rot[0]))
      std::printf(
          "    median statistical sigma (what the window constrains) rot [x y z] deg: %.4f %.4f "
          "%.4f, trans cm: %.3f %.3f %.3f\n",
          stat_rot[0], stat_rot[1], stat_rot[2], stat_trans[0] * 100, stat_trans[1] * 100,
          stat_trans[2] * 100);
    summary_json << "\"" << name << "\": {\"median_abs_rot_err_deg\": " << jsonArray(med_rot, 3)
                 << ", \"median_abs_trans_err_m\": " << jsonArray(med_trans, 3)
                 << ", \"success_rate\": " << success;
    if (std::isfinite(stat_rot[0]))
      summary_json << ", \"median_sigma_statistical_rot_deg\": " << jsonArray(stat_rot, 3)
                   << ", \"median_sigma_statistical_trans_m\": " << jsonArray(stat_trans, 3);
    summary_json << ", \"median_rot_err_norm_deg\": " << jsonNumber(median(rn))
                 << ", \"median_trans_err_norm_m\": " << jsonNumber(median(tn)) << "}, ";
  }
  // The extrinsic the mode does not estimate: named, so that both keys are always there.
  for (const char* name : {"lidar", "stereo"})
    if (std::none_of(estimated.begin(), estimated.end(),
                     [&](const auto& e) { return e.first == name; }))
      summary_json << "\"" << name << "\": {\"estimated\": false}, ";
  return summary_json.str();
}

/// One trial's object in the JSON's "trials" list.
std::string trialJson(const Args& args, const Estimated& estimated, const Trial& tr) {
  const bool with_brightness = args.mode != "lidar_stereo";
  std::ostringstream js;
  js << std::setprecision(10);
  js << "  {\"seed\": " << tr.seed << ", \"window_index\": " << tr.window_index
     << ", \"converged\": " << (tr.converged ? "true" : "false")
     << ", \"success\": " << (trialSuccess(estimated, tr) ? "true" : "false")
     << ", \"lidar\": " << tr.lidar.json() << ", \"stereo\": " << tr.stereo.json();
  if (with_brightness) {
    js << ", \"brightness\": [";
    for (size_t b = 0; b < tr.brightness.size(); ++b)
      js << (b ? ", " : "") << jsonArray(tr.brightness[b].data(), 2);
    js << "]";
  }
  js << ", \"nees\": " << jsonNumber(tr.nees) << ", \"nees_model\": " << jsonNumber(tr.nees_model)
     << ", \"iterations\": " << tr.iterations;
  if (tr.rematches >= 0) js << ", \"rematches\": " << tr.rematches;
  if (tr.yaw_handovers >= 0) js << ", \"yaw_handovers\": " << tr.yaw_handovers;
  if (tr.lidar_first >= 0) js << ", \"lidar_first\": " << (tr.lidar_first ? "true" : "false");
  if (std::isfinite(tr.stereo_scale))
    js << ", \"stereo_scale\": " << jsonNumber(tr.stereo_scale)
       << ", \"stereo_scale_sigma\": " << jsonNumber(tr.stereo_scale_sigma);
  if (std::isfinite(tr.stereo_yaw_deg))
    js << ", \"stereo_yaw_deg\": " << jsonNumber(tr.stereo_yaw_deg);
  // null where not measured (doc/evaluation.md); before session 32 the keys were left out.
  js << ", \"disparity_offset_px\": " << jsonNumber(tr.disparity_offset_px)
     << ", \"disparity_offset_sigma_px\": " << jsonNumber(tr.disparity_offset_sigma_px)
     << ", \"disparity_offset_used\": "
     << (std::isfinite(tr.disparity_offset_px) ? (tr.disparity_offset_used ? "true" : "false")
                                               : "null");
  if (std::isfinite(tr.lidar_error_found[0])) {
    double found[6];
    for (int i = 0; i < 6; ++i)
      found[i] = i < 3 ? tr.lidar_error_found[i] * kDegPerRad : tr.lidar_error_found[i];
    js << ", \"lidar_error_found\": " << jsonArray(found, 6);
  }
  for (const auto& [key, w] : {std::pair{"lidar_weakest_direction", &tr.lidar_weakest},
                               std::pair{"stereo_weakest_direction", &tr.stereo_weakest}}) {
    if (!(w->ratio > 0)) continue;
    js << ", \"" << key << "\": {\"ratio\": " << jsonNumber(w->ratio)
       << ", \"direction\": " << jsonArray(w->direction.data(), 6) << ", \"in_words\": \""
       << describeDirection(w->direction) << "\"}";
  }
  if (tr.halves.tested)
    js << ", \"halves\": {\"chi2\": " << jsonNumber(tr.halves.chi2)
       << ", \"covariance_scale\": " << jsonNumber(tr.halves.covariance_scale)
       << ", \"seconds\": " << jsonNumber(tr.halves.seconds) << "}";
  js << ", \"seconds\": {\"preprocess\": " << jsonNumber(tr.preprocess)
     << ", \"solve\": " << jsonNumber(tr.solve)
     << ", \"total\": " << jsonNumber(tr.preprocess + tr.solve);
  for (const auto& [stage, sec] : tr.stage_seconds)
    js << ", \"" << stage << "\": " << jsonNumber(sec);
  js << "}}";
  return js.str();
}

}  // namespace

bool report(const Args& args, const EvalData& d, const LidarStereoSettings& solver_settings,
            const std::vector<Trial>& trials) {
  const Estimated estimated = estimatedExtrinsics(args);
  std::vector<double> pre, sol, nees, nees_model, nees_converged;
  int ok_all = 0, converged_all = 0;
  for (const auto& tr : trials) {
    pre.push_back(tr.preprocess);
    sol.push_back(tr.solve);
    if (std::isfinite(tr.nees)) nees.push_back(tr.nees);
    if (std::isfinite(tr.nees) && tr.converged) nees_converged.push_back(tr.nees);
    if (std::isfinite(tr.nees_model)) nees_model.push_back(tr.nees_model);
    ok_all += trialSuccess(estimated, tr);
    converged_all += tr.converged;
  }
  double mean_nees_model = std::nan("");
  if (!nees_model.empty()) {
    mean_nees_model = 0;
    for (double v : nees_model) mean_nees_model += v / nees_model.size();
  }
  auto mean = [](const std::vector<double>& v) {
    double m = std::nan("");
    if (!v.empty()) m = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    return m;
  };
  const double mean_nees = mean(nees);
  // Over the trials the estimator declared converged: the estimates an online node publishes.
  const double mean_nees_converged = mean(nees_converged);
  std::printf("\nsummary (%s, %s, %zu window(s) of %zu, %zu trials)\n", args.mode.c_str(),
              args.method.c_str(), d.n_windows, d.window_size, trials.size());
  std::printf("  success rate (< 0.2 deg and < 3 cm%s): %.1f %%; declared converged: %d of %zu\n",
              estimated.size() > 1 ? ", both extrinsics" : "", 100.0 * ok_all / trials.size(),
              converged_all, trials.size());
  const std::string summary_json = printExtrinsicSummaries(estimated, trials);
  std::printf(
      "  time per window: preprocess %.2f s (stereo %.2f s, %zu keyframes), solve median %.2f s\n",
      median(pre), d.stereo_seconds / d.n_windows, d.window_size, median(sol));
  if (std::isfinite(mean_nees)) {
    std::printf("  mean NEES (6 DoF, ideal 6): %.2f", mean_nees);
    if (nees.size() < trials.size())  // the others have no covariance (covariance_known)
      std::printf(" (over the %zu of %zu trials with a covariance)", nees.size(), trials.size());
    std::printf("\n");
  }
  if (std::isfinite(mean_nees_converged))
    std::printf("  mean NEES of the %zu converged trials: %.2f\n", nees_converged.size(),
                mean_nees_converged);
  if (std::isfinite(mean_nees_model))
    std::printf("  mean NEES with the paper's covariance alone (eq. residual_uncertainty): %.2f\n",
                mean_nees_model);
  printSplitWindowCheck(trials);
  printWeakestDirections(trials);
  printDisparityOffsets(trials, solver_settings);
  printLidarNuisance(trials);

  if (!args.json.empty()) {
    std::ofstream js(args.json);
    if (!js) {
      std::cerr << "tescalib_eval: cannot write " << args.json << "\n";
      return false;
    }
    js << std::setprecision(10) << "{\"mode\": \"" << args.mode << "\", \"method\": \""
       << args.method << "\", \"window\": " << d.window_size << ", \"windows\": " << d.n_windows
       << ", \"seed\": " << args.seed << ", \"init_rot_deg\": " << args.init_rot_deg
       << ", \"init_trans_m\": " << args.init_trans_m
       << ", \"init_stereo_rot_deg\": " << args.init_stereo_rot_deg
       << ", \"init_stereo_trans_m\": " << args.init_stereo_trans_m
       << ", \"refinement\": {\"iterations\": " << d.used_refinement.iterations
       << ", \"smoothed_rounds\": " << d.used_refinement.smoothed_gradient_rounds
       << "}, \"consistent_sample\": " << (args.consistent_sample ? "true" : "false")
       << ", \"trials\": [\n";
    for (size_t i = 0; i < trials.size(); ++i) {
      js << trialJson(args, estimated, trials[i]) << (i + 1 < trials.size() ? ",\n" : "\n");
    }
    js << "], \"summary\": {" << summary_json
       << "\"success_rate\": " << double(ok_all) / trials.size()
       << ", \"declared_converged_rate\": " << double(converged_all) / trials.size()
       << ", \"mean_nees\": " << jsonNumber(mean_nees)
       << ", \"mean_nees_converged\": " << jsonNumber(mean_nees_converged)
       << ", \"mean_nees_model\": " << jsonNumber(mean_nees_model)
       << ", \"seconds\": {\"preprocess\": " << jsonNumber(median(pre))
       << ", \"solve\": " << jsonNumber(median(sol)) << "}}}\n";
    std::cout << "wrote " << args.json << "\n";
  }
  return true;
}

}  // namespace tescalib::eval
