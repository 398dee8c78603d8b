// tescalib_validate: scores calibrations of one recording with criteria that do not share the
// solvers' objectives (edge alignment, photometric consistency, the stereo-LiDAR disparity
// residual; validation_set.h), each with its frames' standard error and its sensitivity to a
// 0.1 deg / 1 cm step per axis: "is my calibration right?" without a reference.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/validation/optimum_uncertainty.h"
#include "tescalib/core/validation/validation.h"
#include "validate_bag.h"
#include "validate_report.h"

namespace {

using namespace tescalib;

const char* const kUsage =
    "usage: rosrun tescalib tescalib_validate --sequences DIR[,DIR...] | --bag FILE\n"
    "         [--calib NAME=FILE ...] [--frames SPEC] [--json FILE]";
const char* const kDescription =
    "Scores the recording's own calibration and every --calib on the recording's frames with "
    "three criteria independent of the solvers: edge alignment (LiDAR depth discontinuities on "
    "image edges, left and right image; higher is better), photometric residual (left vs right "
    "brightness at the LiDAR points, grey levels; lower is better) and disparity residual (SGBM "
    "vs the LiDAR-predicted disparity, px; lower is better). Prints a row per calibration with "
    "each score's difference to the best and whether it is significant (95 %, over the frames), "
    "and per criterion the axes along which it would move the calibration.";
const char* const kFooter =
    "Exit status: 0 when every calibration was scored, 1 when the data or a calibration file "
    "cannot be used, 2 on a usage error.";

struct Args {
  std::vector<std::string> sequences;
  std::string bag;
  BagTopics topics;
  std::vector<std::pair<std::string, std::string>> calibs;  // NAME, FILE
  std::string frames = "keyframes";
  std::string json;
  bool optimum = false;
  std::vector<std::string> fit_sequences;      // --fit-sequences; empty: the optima on --sequences
  std::string fit_frames;                      // --fit-frames; empty: --frames
  double perturbed_deg = 0, perturbed_cm = 0;  // --perturbed; 0: none
  double step_rot_deg = 0.1, step_trans_m = 0.01;
};

std::pair<std::string, std::string> nameAndFile(const std::string& v) {
  const size_t eq = v.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == v.size() || v.substr(0, eq) == "recording")
    throw std::invalid_argument(v);
  return {v.substr(0, eq), v.substr(eq + 1)};
}

/// The recording: folders or a bag with its topics.
void addInputOptions(CLI::App* app, Args* a) {
  cli::add(app, "--sequences", "DIR[,DIR...]",
           cli::to(&a->sequences, [](const std::string& v) { return cli::splitList(v); }),
           "KITTI folders (odometry or raw layout, or tescalib_simulate output) of one rig");
  cli::add(app, "--bag", "FILE", cli::to(&a->bag, cli::text),
           "a rosbag with kitti2bag's topics (or --points, --left, --right): intrinsics from "
           "camera_info, the recording's T_cam_lidar from /tf_static; --frames numbers count "
           "its synchronized sets");
  cli::add(app, "--points", "TOPIC", cli::to(&a->topics.points, cli::text),
           "--bag: the point cloud topic");
  cli::add(app, "--left", "IMAGE_TOPIC", cli::imageTopic(&a->topics.left, &a->topics.left_info),
           "--bag: the left image topic (raw or .../compressed); camera_info is the image "
           "topic's folder + /camera_info");
  cli::add(app, "--right", "IMAGE_TOPIC", cli::imageTopic(&a->topics.right, &a->topics.right_info),
           "--bag: the right image topic, as --left");
}

bool parseArgs(int argc, char** argv, Args* a) {
  CLI::App app(kDescription, "tescalib_validate");
  cli::setUp(&app, kUsage, "Options");
  app.footer(kFooter);
  addInputOptions(&app, a);
  app.add_option_function<std::vector<std::string>>(
         "--calib",
         [a](const std::vector<std::string>& v) {
           for (const std::string& s : v) {
             try {
               a->calibs.push_back(nameAndFile(s));
             } catch (const std::invalid_argument&) {
               throw CLI::ValidationError("bad value '" + s + "' for --calib (NAME=FILE)");
             }
           }
         },
         "a calibration to score: NAME=FILE, FILE a result (BASE.yaml) or a KITTI calib.txt "
         "(only its extrinsics are used); repeat for more")
      ->type_name("NAME=FILE")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cli::add(&app, "--frames", "SPEC", cli::to(&a->frames, cli::text),
           "keyframes (default: frames 0.5 s apart), all, or frame numbers of every folder: "
           "0-9,20 or 0-40:5 (a range with a step)");
  cli::add(&app, "--json", "FILE", cli::to(&a->json, cli::text), "also write the scores as JSON");
  cli::add(&app, "--optimum", "0|1", cli::to(&a->optimum, cli::toSwitch),
           "also search each criterion's optimum near every calibration (direction-set search, "
           "slower) and print how far it lies, how much better it scores, its 1-sigma uncertainty "
           "per axis (the frames' scatter and the criterion's floor) and whether the calibration "
           "lies within its 95 %");
  cli::add(&app, "--fit-sequences", "DIR[,DIR...]",
           cli::to(&a->fit_sequences, [](const std::string& v) { return cli::splitList(v); }),
           "search the optima on these folders' frames (of the same rig) instead, and score "
           "them on --sequences' frames: held out from the fit (implies --optimum 1)");
  cli::add(&app, "--fit-frames", "SPEC", cli::to(&a->fit_frames, cli::text),
           "the frames to search the optima on (of --fit-sequences, else of the recording; "
           "default: --frames)");
  cli::add(
      &app, "--perturbed", "DEG,CM",
      [a](const std::string& v) {
        const std::vector<std::string> p = cli::splitList(v);
        if (p.size() != 2) throw std::invalid_argument(v);
        a->perturbed_deg = cli::toNonNegative(p[0]);
        a->perturbed_cm = cli::toNonNegative(p[1]);
      },
      "also score the recording's calibration moved by DEG about and CM along each axis of "
      "the left camera, either way (12 rows, e.g. rx+0.5 tz-5): whether the criteria tell "
      "such a calibration from the recording's on these frames");
  cli::add(&app, "--step-deg", "DEG", cli::to(&a->step_rot_deg, cli::toNonNegative),
           "rotation step of the sensitivities (default 0.1)");
  cli::add(
      &app, "--step-cm", "CM",
      [a](const std::string& v) { a->step_trans_m = cli::toNonNegative(v) / 100; },
      "translation step of the sensitivities (default 1)");
  if (argc < 2) {
    std::cout << app.help();
    return false;
  }
  if (!cli::parse(&app, argc, argv)) return false;
  if (!a->fit_sequences.empty() || !a->fit_frames.empty()) a->optimum = true;
  std::string problem;
  if (a->sequences.empty() == a->bag.empty())
    problem = "give --sequences DIR[,DIR...] or --bag FILE (one of the two)";
  if (!a->bag.empty() && !a->fit_sequences.empty())
    problem = "--fit-sequences goes with --sequences (with --bag: --fit-frames)";
  if (a->step_rot_deg <= 0 || a->step_trans_m <= 0) problem = "the steps must be above 0";
  if (!a->json.empty() && !cli::missingFolder(a->json).empty())
    problem = "--json: the folder " + cli::missingFolder(a->json) + " does not exist";
  if (problem.empty()) return true;
  std::cerr << "tescalib_validate: " << problem << " (--help lists the options)\n";
  return false;
}

/// The frame numbers SPEC names ("0-9,20", "0-40:5"). Throws DataError on a bad SPEC.
std::set<int> frameNumbers(const std::string& spec) {
  std::set<int> out;
  for (const std::string& item : cli::splitList(spec)) {
    try {
      const size_t dash = item.find('-'), colon = item.find(':');
      const int first = cli::toInt(item.substr(0, std::min(dash, colon)));
      int last = first, step = 1;
      if (dash != std::string::npos)
        last = cli::toInt(item.substr(
            dash + 1, colon == std::string::npos ? std::string::npos : colon - dash - 1));
      if (colon != std::string::npos) step = cli::toInt(item.substr(colon + 1));
      if (first < 0 || last < first || step < 1) throw std::invalid_argument(item);
      for (int f = first; f <= last; f += step) out.insert(f);
    } catch (const std::exception&) {
      throw DataError("--frames: bad item '" + item + "' (keyframes, all, or 0-9,20 or 0-40:5)");
    }
  }
  return out;
}

/// The chosen frames of every folder, and a label "FOLDER:FRAME" for each.
std::vector<Frame> loadFrames(const std::vector<std::unique_ptr<KittiSequence>>& seqs,
                              const std::string& spec, std::vector<std::string>* labels) {
  std::vector<Frame> frames;
  const std::set<int> numbers =
      spec == "keyframes" || spec == "all" ? std::set<int>() : frameNumbers(spec);
  for (const auto& seq : seqs) {
    std::vector<size_t> idx;
    if (spec == "keyframes") idx = seq->keyframes(0.5);
    for (size_t i = 0; spec != "keyframes" && i < seq->size(); ++i)
      if (spec == "all" || numbers.count(seq->frameId(i))) idx.push_back(i);
    const std::string name = std::filesystem::path(seq->dir()).filename().string();
    for (size_t i : idx) {
      frames.push_back(seq->load(i));
      labels->push_back(name + ":" + std::to_string(seq->frameId(i)));
    }
  }
  if (frames.empty()) throw DataError("--frames " + spec + ": none of these frames exists");
  return frames;
}

/// A --calib file's extrinsics: a result (BASE.yaml) or a KITTI calib.txt.
validate::Scored readCalibration(const std::string& name, const std::string& path,
                                 const StereoRig& rig) {
  validate::Scored s;
  s.name = name;
  s.source = path;
  if (path.size() > 5 && path.compare(path.size() - 5, 5, ".yaml") == 0) {
    const CalibrationFile f = readCalibrationYaml(path);
    s.T_cam_lidar = f.T_cam_lidar;
    s.T_right_left = f.T_right_left;
    return s;
  }
  const StereoRig r = readCheckedOdometryRig(path);
  if (std::fabs(r.left.fx - rig.left.fx) > 1e-3)
    std::printf("note: %s has fx %.3f, the data %.3f: only its extrinsics are used\n", path.c_str(),
                r.left.fx, rig.left.fx);
  s.T_cam_lidar = r.T_cam_lidar;
  s.T_right_left = r.T_right_left;
  return s;
}

/// The rows of --perturbed: the recording's calibration moved along each axis, either way.
void addPerturbed(const Args& args, std::vector<validate::Scored>* all) {
  if (args.perturbed_deg <= 0 && args.perturbed_cm <= 0) return;
  const char* const axes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  const validate::Scored recording = all->front();
  for (int k = 0; k < 6; ++k)
    for (int sign : {1, -1}) {
      const double size = k < 3 ? args.perturbed_deg : args.perturbed_cm;
      if (size <= 0) continue;
      Vector6d d = Vector6d::Zero();
      d(k) = sign * (k < 3 ? size / kDegPerRad : size / 100);
      validate::Scored s = recording;
      char name[32];
      std::snprintf(name, sizeof(name), "%s%c%g", axes[k], sign > 0 ? '+' : '-', size);
      s.name = name;
      s.source = std::string("recording moved ") + (k < 3 ? "deg" : "cm");
      s.T_cam_lidar = perturb(recording.T_cam_lidar, d);
      s.perturbed = true;
      all->push_back(s);
    }
}

/// A recording's frames: its rig (with its own calibration), the frames and their labels.
struct Recording {
  StereoRig rig;
  std::vector<Frame> frames;
  std::vector<std::string> labels;
  std::string source;  ///< where the recording's calibration comes from
};

/// The frames `spec` names of the folders `dirs` or, with --bag, of the bag.
Recording loadRecording(const Args& args, const std::vector<std::string>& dirs,
                        const std::string& spec) {
  Recording r;
  if (!args.bag.empty()) {
    const bool named = spec == "keyframes" || spec == "all";
    validate::BagRecording b = validate::readBagRecording(
        args.bag, args.topics, spec, named ? std::set<int>() : frameNumbers(spec));
    r.rig = b.rig;
    r.frames = std::move(b.frames);
    r.labels = std::move(b.labels);
    r.source = args.bag + " camera_info and /tf_static";
    return r;
  }
  const auto seqs = openSequences(dirs);
  r.rig = seqs.front()->rig();
  r.frames = loadFrames(seqs, spec, &r.labels);
  r.source = dirs.front() + " calibration";
  return r;
}

/// The frames of --fit-sequences / --fit-frames, prepared (nullptr when neither is given).
/// Throws DataError when their rig is not the recording's.
std::unique_ptr<ValidationSet> fitSet(const Args& args, const ValidationSettings& settings,
                                      const StereoRig& rig, std::vector<std::string>* labels) {
  if (args.fit_sequences.empty() && args.fit_frames.empty()) return nullptr;
  if (!args.fit_sequences.empty()) {
    std::vector<std::string> dirs = args.sequences;
    dirs.insert(dirs.end(), args.fit_sequences.begin(), args.fit_sequences.end());
    openSequences(dirs);  // one rig
  }
  const Recording fit =
      loadRecording(args, args.fit_sequences.empty() ? args.sequences : args.fit_sequences,
                    args.fit_frames.empty() ? args.frames : args.fit_frames);
  *labels = fit.labels;
  return std::make_unique<ValidationSet>(fit.frames, rig, settings);
}

int run(const Args& args) {
  const Recording recording = loadRecording(args, args.sequences, args.frames);
  const StereoRig& rig = recording.rig;
  const std::vector<Frame>& frames = recording.frames;
  const std::vector<std::string>& labels = recording.labels;
  std::vector<validate::Scored> all(1);
  all[0].name = "recording";
  all[0].source = recording.source;
  all[0].T_cam_lidar = rig.T_cam_lidar;
  all[0].T_right_left = rig.T_right_left;
  for (const auto& [name, path] : args.calibs) all.push_back(readCalibration(name, path, rig));
  addPerturbed(args, &all);
  ValidationSettings settings;
  settings.step_rot_deg = args.step_rot_deg;
  settings.step_trans_m = args.step_trans_m;
  ValidationSet set(frames, rig, settings);
  std::printf("%zu frames, %zu calibrations\n", frames.size(), all.size());
  std::vector<std::string> fit_labels;
  const std::unique_ptr<ValidationSet> fit_set = fitSet(args, settings, rig, &fit_labels);
  ValidationSet& fit = fit_set ? *fit_set : set;
  if (fit_set)
    std::printf("the optima searched on %zu other frames, scored on these\n", fit_labels.size());
  std::printf("\n");
  for (validate::Scored& s : all) {
    s.validation = validateCalibration(set, s.T_cam_lidar, s.T_right_left, !s.perturbed);
    if (!args.optimum || s.perturbed) continue;
    s.has_optima = true;
    s.optima_held_out = fit_set != nullptr;
    for (Criterion c : kAllCriteria) {
      const int i = static_cast<int>(c);
      s.optima[i] = criterionOptimum(fit, c, s.T_cam_lidar, s.T_right_left, 5);
      s.optimum_scores[i] = set.score(s.optima[i], s.T_right_left, {c})[i];
      s.optimum_uncertainty[i] = optimumUncertainty(fit, c, s.optima[i], s.T_right_left);
    }
  }
  std::fputs(validate::scoreTable(all, settings).c_str(), stdout);
  if (args.json.empty()) return 0;
  std::ofstream out(args.json);
  nlohmann::json j = validate::validationJson(all, settings, labels);
  if (fit_set) j["optima_fitted_on"] = fit_labels;
  out << j.dump(2) << "\n";
  if (!out) {
    std::fprintf(stderr, "tescalib_validate: cannot write %s\n", args.json.c_str());
    return 1;
  }
  std::printf("wrote %s\n", args.json.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parseArgs(argc, argv, &args)) return 2;
  try {
    return run(args);
  } catch (const DataError& e) {
    std::fprintf(stderr, "tescalib_validate: %s\n", e.what());
    return 1;
  }
}
