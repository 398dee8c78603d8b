#include "eval_monitor.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/eval/monitor_score.h"
#include "tescalib/core/io/kitti_calib.h"
#include "tescalib/core/io/sim_info.h"

namespace tescalib::eval {
namespace {

namespace fs = std::filesystem;
using Run = std::map<std::string, std::vector<MonitoredEstimate>>;

/// Both extrinsics' truth over the drive: calib.txt (calib_true.txt's right camera when there
/// is one), calib_after_step.txt from sim_info.txt's extrinsic_step_at_s on.
std::map<std::string, ExtrinsicTruth> readTruth(const fs::path& dir) {
  const fs::path true_calib = dir / "calib_true.txt";
  const StereoRig before =
      readCheckedOdometryRig((fs::exists(true_calib) ? true_calib : dir / "calib.txt").string());
  std::map<std::string, ExtrinsicTruth> truth;
  truth["lidar_to_left"].before = truth["lidar_to_left"].after = before.T_cam_lidar;
  truth["left_to_right"].before = truth["left_to_right"].after = before.T_right_left;
  const auto info = readSimInfo(dir.string());
  if (!info.count("extrinsic_step_at_s")) return truth;
  const StereoRig after = readCheckedOdometryRig((dir / "calib_after_step.txt").string());
  const bool stereo = info.count("extrinsic_step") && info.at("extrinsic_step") == "stereo";
  ExtrinsicTruth& stepped = truth[stereo ? "left_to_right" : "lidar_to_left"];
  stepped.after = stereo ? after.T_right_left : after.T_cam_lidar;
  stepped.step_at = std::stod(info.at("extrinsic_step_at_s"));
  return truth;
}

MonitoredEstimate estimateFrom(const nlohmann::json& e) {
  MonitoredEstimate m;
  m.time = e.at("time").get<double>();
  m.published = e.at("published").get<bool>();
  const auto T = e.at("T").get<std::vector<double>>();
  const auto C = e.at("covariance").get<std::vector<double>>();
  if (T.size() != 16 || C.size() != 36) throw DataError("T needs 16 numbers, covariance 36");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.T.matrix()(r, c) = T[4 * r + c];
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) m.covariance(r, c) = C[6 * r + c];
  if (!parseMonitorState(e.at("monitor").get<std::string>(), &m.monitor))
    throw DataError("unknown monitor state " + e.at("monitor").dump());
  return m;
}

Run readRun(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw DataError(path + ": cannot read");
  Run run;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    for (const auto& e : j.at("estimates"))
      run[e.at("extrinsic").get<std::string>()].push_back(estimateFrom(e));
  } catch (const nlohmann::json::exception& e) {
    throw DataError(path + ": not a tescalib_calibrate --json file (" + e.what() + ")");
  } catch (const DataError& e) {
    throw DataError(path + ": " + e.what());
  }
  return run;
}

nlohmann::json number(double v) { return std::isnan(v) ? nlohmann::json() : nlohmann::json(v); }

nlohmann::json toJson(const MonitorScore& s, const ExtrinsicTruth& truth) {
  return {{"step_at_s", number(truth.steps() ? truth.step_at : NAN)},
          {"solves", s.solves},
          {"published", s.published},
          {"suspect_share", s.suspect_share},
          {"changes", s.changes},
          {"false_changes", s.false_changes},
          {"suspect_delay_s", number(s.suspect_delay)},
          {"changed_delay_s", number(s.changed_delay)},
          {"first_published_delay_s", number(s.first_published_delay)},
          {"first_published_rot_deg", number(s.first_published_rot_deg)},
          {"first_published_trans_m", number(s.first_published_trans_m)},
          {"recovered_delay_s", number(s.recovered_delay)},
          {"worse_replacements", s.worse_replacements},
          {"last_rot_deg", number(s.last_rot_deg)},
          {"last_trans_m", number(s.last_trans_m)}};
}

std::string delay(double s) {
  if (std::isnan(s)) return "never";
  char buf[32];
  std::snprintf(buf, sizeof buf, "+%.1f s", s);
  return buf;
}

void print(const std::string& name, const MonitorScore& s, const ExtrinsicTruth& truth) {
  std::printf(
      "%s: %d solves, %d published, suspect in %.0f %% of them, changed declared %d "
      "time(s) (%d before the step or without one)\n",
      name.c_str(), s.solves, s.published, 100 * s.suspect_share, s.changes, s.false_changes);
  if (truth.steps()) {
    std::printf(
        "  after the step at %.2f s: suspect %s, changed %s; first published estimate "
        "%s (%.3f deg, %.2f cm from the new truth); within 0.05 deg / 1 cm %s; %d "
        "published estimate(s) farther from the truth than the one they replaced\n",
        truth.step_at, delay(s.suspect_delay).c_str(), delay(s.changed_delay).c_str(),
        delay(s.first_published_delay).c_str(), s.first_published_rot_deg,
        100 * s.first_published_trans_m, delay(s.recovered_delay).c_str(), s.worse_replacements);
  }
  std::printf("  last published estimate: %.3f deg, %.2f cm from the truth at the end\n",
              s.last_rot_deg, 100 * s.last_trans_m);
}

}  // namespace

bool scoreEstimates(const Args& args) {
  if (args.sequences.size() != 1) {
    std::cerr << "tescalib_eval: --score-estimates scores one drive: give one --sequences folder\n";
    return false;
  }
  try {
    const auto truth = readTruth(args.sequences[0]);
    const Run run = readRun(args.score_estimates);
    nlohmann::json out = {{"drive", args.sequences[0]}, {"estimates", args.score_estimates}};
    for (const auto& [name, estimates] : run) {
      if (!truth.count(name)) throw DataError("unknown extrinsic " + name);
      const MonitorScore s = scoreMonitorRun(estimates, truth.at(name));
      print(name, s, truth.at(name));
      out["extrinsics"][name] = toJson(s, truth.at(name));
    }
    if (!args.json.empty()) {
      std::ofstream f(args.json);
      if (!(f << out.dump(1) << "\n")) throw DataError(args.json + ": cannot write");
    }
  } catch (const std::exception& e) {  // DataError, and a sim_info.txt number std::stod rejects
    std::cerr << "tescalib_eval: " << e.what() << "\n";
    return false;
  }
  return true;
}

}  // namespace tescalib::eval
