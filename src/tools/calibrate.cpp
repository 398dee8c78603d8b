// tescalib_calibrate: calibrates a recording offline, as fast as the CPU allows, without a ROS
// master. It feeds the keyframes of KITTI-layout folders (odometry or raw layout, or
// tescalib_simulate output) or of a rosbag through the same OnlineCalibrator the nodelet runs,
// from the data's own calibration (folders: calib.txt; bags: camera_info and /tf_static) or
// --init FILE as the initial guess, prints every estimate the node would publish, and writes the
// last one as the node's ~save service does (BASE.yaml, BASE_calib.txt, BASE_static_tf.launch).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2/exceptions.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/overlay.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/ros/bag_sets.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/frame_intake.h"
#include "tescalib/ros/params.h"

#include "calibrate_args.h"
#include "calibrate_monitor.h"
#include "calibrate_print.h"
#include "calibrate_quality.h"
#include "calibrate_split.h"
#include "cli.h"

using namespace tescalib;
using calibrate::appendToResultYaml;
using calibrate::Args;
using calibrate::ExtrinsicReport;
using calibrate::pose6;
using calibrate::printQuality;
using calibrate::windowSize;

namespace {

/// Feeds frames to the calibrator, solves as the node does after each new keyframe, and prints
/// what happened to each keyframe.
struct Session {
  OnlineSettings settings;
  std::unique_ptr<OnlineCalibrator> calibrator;  // made once the initial guess is known
  Eigen::Isometry3d T_initial, T_reference, T_reference_stereo;
  std::string reference = "the data's calibration";  // what T_reference is, for the printouts
  bool perturbed = false;
  int keyframes = 0, rejected = 0, solves = 0, published = 0;
  std::vector<std::pair<int, double>> published_nees;  ///< (keyframes used, NEES), --perturb-*
  int nees_skipped = 0;  ///< published estimates whose covariance was not positive definite
  std::string last_solve;
  std::string lidar_frame = "velo_link";  // the data's (a bag's cloud frame); --lidar-frame wins
  bool keep_last_keyframe = false;        // --overlay
  Frame last_keyframe;                    // its left image and scan, kept only for --overlay
  std::vector<Frame> window_keyframes;    // the last window's keyframes, for the quality scores
  StereoRig initial_rig;                  // the initial guess, for the quality scores
  calibrate::MonitorLog monitor;          // the monitor's changes, --json's estimates

  /// The rig with its initial extrinsics; with --perturb-*, T_cam_lidar is moved away from them
  /// (they stay the reference of the printed errors).
  void start(StereoRig rig, const Args& args, const std::string& source) {
    T_reference = rig.T_cam_lidar;
    T_reference_stereo = rig.T_right_left;
    if (!args.init.empty()) reference = "the --init calibration";
    perturbed = args.perturb_rot_deg > 0 || args.perturb_trans_m > 0;
    if (perturbed) {
      std::mt19937_64 rng(args.seed);
      rig.T_cam_lidar =
          perturb(rig.T_cam_lidar,
                  randomPerturbation(args.perturb_rot_deg / kDegPerRad, args.perturb_trans_m, rng));
    }
    T_initial = rig.T_cam_lidar;
    initial_rig = rig;
    std::printf("tescalib_calibrate: %s, mode %s, window %d, %dx%d, fx %.2f, baseline %.4f m%s\n",
                source.c_str(), args.mode.c_str(), settings.window_size, rig.left.width,
                rig.left.height, rig.left.fx, rig.baseline(),
                settings.deskew ? ", scans de-skewed" : "");
    if (perturbed)
      std::printf("initial T_cam_lidar %s from %s\n",
                  pose6(poseError(rig.T_cam_lidar, T_reference)).c_str(), reference.c_str());
    calibrator = std::make_unique<OnlineCalibrator>(rig, settings);
  }

  void add(const Frame& frame, double lidar_stamp, const std::string& label) {
    std::string msg;
    const FrameResult r = calibrator->addFrame(frame, lidar_stamp, &msg);
    took(r, msg, frame, label);
  }

  /// A bag's candidate, with de-skewing after its previous scan.
  void add(const CandidateFrame& candidate, const std::string& label) {
    std::string msg;
    const FrameResult r = candidate.addTo(calibrator.get(), &msg);
    took(r, msg, candidate.frame, label);
  }

  /// What the calibrator made of `frame`; after each new keyframe a solve once the window is
  /// ready.
  void took(FrameResult r, const std::string& msg, const Frame& frame, const std::string& label) {
    if (r == FrameResult::kRejected) {
      std::printf("  %s rejected: %s\n", label.c_str(), msg.c_str());
      ++rejected;
      return;
    }
    if (r == FrameResult::kReset) std::printf("  %s: %s\n", label.c_str(), msg.c_str());
    if (r != FrameResult::kKeyframe) return;
    ++keyframes;
    if (keep_last_keyframe) last_keyframe = frame;
    window_keyframes.push_back(frame);
    if (static_cast<int>(window_keyframes.size()) > settings.window_size)
      window_keyframes.erase(window_keyframes.begin());
    if (!msg.empty()) std::printf("  %s: %s\n", label.c_str(), msg.c_str());
    if (!calibrator->readyToSolve()) return;
    solveAndPrint("keyframe " + std::to_string(keyframes) + " (" + label + ")", false);
  }

  /// The end of the input: with --mode co, a recording shorter than the window whose LiDAR-first
  /// solves were never trusted has not been co-calibrated yet (the node waits for a full window
  /// or a published estimate); its keyframes are co-calibrated once now.
  void finish() {
    if (!calibrator || !settings.estimate_stereo) return;
    const auto last = calibrator->lastSolve();
    if (!calibrator->coCalibrationPending()) {
      if (!(last && last->stereo_estimated) &&
          static_cast<int>(calibrator->windowFill()) < settings.min_keyframes_co)
        std::printf(
            "  end of the input: %zu keyframes, co-calibration needs %d: T_right_left was "
            "not estimated\n",
            calibrator->windowFill(), settings.min_keyframes_co);
      return;
    }
    std::printf(
        "  end of the input: %zu keyframes, %s, so not co-calibrated yet; co-calibrating "
        "them\n",
        calibrator->windowFill(),
        calibrator->estimate()
            ? "the LiDAR-stereo estimate came with the last keyframe"
            : ("fewer than the window's " + std::to_string(settings.window_size) +
               " and no LiDAR-stereo estimate trusted")
                  .c_str());
    solveAndPrint("all " + std::to_string(calibrator->windowFill()) + " keyframes", true);
  }

  void solveAndPrint(const std::string& what, bool recording_ended) {
    const bool changed = calibrator->solve(&last_solve, nullptr, recording_ended);
    ++solves;
    monitor.afterSolve(*calibrator, changed);
    std::printf("  %s: ", what.c_str());
    const auto e = calibrator->estimate();
    if (changed && e) {
      ++published;
      std::printf("new estimate");
      if (perturbed) {
        // Against the data's calibration (the truth of a generated drive): does the published
        // covariance cover the error? (doc/evaluation.md: NEES, ideal mean 6.)
        const Vector6d err = poseError(e->T_cam_lidar, T_reference);
        const double n = nees(err, e->cov_lidar);
        std::printf(", error %s, NEES %.1f (%d keyframes)", pose6(err).c_str(), n,
                    e->keyframes_used);
        if (std::isfinite(n))
          published_nees.push_back({e->keyframes_used, n});
        else
          ++nees_skipped;
        if (e->stereo_estimated)
          std::printf(", T_right_left NEES %.1f",
                      nees(poseError(e->T_right_left, T_reference_stereo), e->cov_stereo));
      }
      std::printf(", %.2f s\n", e->solve_seconds);
    } else {
      std::printf("%s\n", last_solve.c_str());
    }
  }

  /// --overlay: the last keyframe's left image with the scan drawn with the initial guess (top)
  /// and with `T` (bottom), `label` saying which estimate that is.
  /// False when the file could not be written.
  bool writeOverlay(const std::string& path, const Eigen::Isometry3d& T,
                    const std::string& label) const {
    if (last_keyframe.left.empty()) {
      std::printf("no keyframe: no overlay written\n");
      return true;
    }
    const CameraIntrinsics& cam = calibrator->rig().left;
    cv::Mat before = last_keyframe.left.clone(), after = last_keyframe.left.clone();
    drawLidarOverlay(last_keyframe.scan, T_initial, cam, &before);
    drawStatusText({"initial T_cam_lidar"}, &before);
    drawLidarOverlay(last_keyframe.scan, T, cam, &after);
    drawStatusText({label}, &after);
    cv::Mat both;
    cv::vconcat(before, after, both);
    bool written = false;
    try {
      written = cv::imwrite(path, both);
    } catch (const cv::Exception&) {  // an unknown extension
    }
    if (written)
      std::printf("overlay written to %s\n", path.c_str());
    else
      std::cerr << "tescalib_calibrate: cannot write " << path << "\n";
    return written;
  }

  /// --perturb-*: the published estimates' NEES (LiDAR extrinsic) against the data's
  /// calibration, all and split at the full window. Successive estimates share keyframes, so
  /// they are not independent samples.
  void reportNees() const {
    if (published_nees.empty()) return;
    double all = 0, part = 0, full = 0;
    int n_part = 0, n_full = 0;
    for (const auto& [kfs, n] : published_nees) {
      all += n;
      if (kfs < settings.window_size)
        part += n, ++n_part;
      else
        full += n, ++n_full;
    }
    std::printf(
        "NEES of the %zu published T_cam_lidar against %s (6 DoF, "
        "ideal mean 6; successive estimates share keyframes): mean %.2f",
        published_nees.size(), reference.c_str(), all / published_nees.size());
    if (n_part)
      std::printf("; from fewer than %d keyframes %.2f (%d)", settings.window_size, part / n_part,
                  n_part);
    if (n_full) std::printf("; from full windows %.2f (%d)", full / n_full, n_full);
    if (nees_skipped)
      std::printf("; %d more without a positive definite covariance (NEES nan)", nees_skipped);
    std::printf("\n");
  }

  /// The frames of the printed extrinsics and of --out's files: the LiDAR's (--lidar-frame, a
  /// bag's cloud frame or velo_link) and the cameras' as the node publishes them.
  CalibrationFrames frames(const Args& args) const {
    CalibrationFrames f;
    f.lidar = args.lidar_frame.empty() ? lidar_frame : args.lidar_frame;
    return f;
  }

  /// T_cam_lidar of an estimate or of the last solve (`published` false), for the printout.
  ExtrinsicReport lidarReport(const OnlineEstimate& e, const Args& args, bool published) const {
    const CalibrationFrames f = frames(args);
    ExtrinsicReport r{"LiDAR -> left camera", f.lidar, f.left, e.T_cam_lidar, e.cov_lidar};
    r.covariance_known = e.cov_lidar_known;
    r.observable = e.observable_lidar;
    r.published = published;
    r.limit_rot_deg = settings.co.lidar.max_sigma_rot_deg;
    r.limit_trans_m = settings.co.lidar.max_sigma_trans_m;
    r.weakest = e.weakest_lidar;
    return r;
  }

  /// T_right_left, as lidarReport.
  ExtrinsicReport stereoReport(const OnlineEstimate& e, const Args& args, bool published) const {
    const CalibrationFrames f = frames(args);
    ExtrinsicReport r{"left -> right camera", f.left, f.right, e.T_right_left, e.cov_stereo};
    r.covariance_known = e.cov_stereo_known;
    r.observable = e.observable_stereo;
    r.published = published;
    r.limit_rot_deg = settings.co.stereo.max_sigma_rot_deg;
    r.limit_trans_m = settings.co.stereo.max_sigma_trans_m;
    r.weakest = e.weakest_stereo;
    return r;
  }

  /// The final estimate (or the last untrusted solve), the files; the exit status.
  int report(const Args& args, double seconds) const {
    std::printf("%d keyframes, %d rejected, %d solves, %d estimates, %.1f s\n", keyframes, rejected,
                solves, published, seconds);
    reportNees();
    const auto e = calibrator ? calibrator->estimate() : std::nullopt;
    if (!e) {
      std::printf("no converged estimate%s%s\n", last_solve.empty() ? "" : ": ",
                  last_solve.c_str());
      if (keyframes < settings.minKeyframes())
        std::printf("(%d keyframes; a solve needs %d)\n", keyframes, settings.minKeyframes());
      if (const auto c = calibrator ? calibrator->lastSolve() : std::nullopt) {
        // What the window gives, untrusted: for a look, not for use (nothing is written).
        std::printf("the last solve's result, not trusted (%d keyframes):\n", c->keyframes_used);
        printExtrinsic(lidarReport(*c, args, false));
        if (c->stereo_estimated) printExtrinsic(stereoReport(*c, args, false));
        std::printf("change from the initial guess: %s\n",
                    pose6(poseError(c->T_cam_lidar, T_initial)).c_str());
        printQuality(window_keyframes, initial_rig, c->T_cam_lidar, c->T_right_left);
        if (!args.overlay.empty())
          writeOverlay(
              args.overlay, c->T_cam_lidar,
              "the last solve, NOT TRUSTED (weak: " + untrustedAxes(c->observable_lidar) + ")");
      }
      return 1;
    }
    std::printf("estimate from %d keyframes:\n", e->keyframes_used);
    printExtrinsic(lidarReport(*e, args, true));
    if (e->stereo_estimated) {
      printExtrinsic(stereoReport(*e, args, true));
    } else
      std::printf("left -> right camera, %s -> %s: as calibrated (%s)\n", frames(args).left.c_str(),
                  frames(args).right.c_str(),
                  settings.estimate_stereo
                      ? "no co-calibrated estimate was published; the last solve's message says why"
                      : "not estimated; --mode co or joint estimates it");
    std::printf("change from the initial guess: %s\n",
                pose6(poseError(e->T_cam_lidar, T_initial)).c_str());
    if (perturbed) {
      std::printf("error against %s: %s\n", reference.c_str(),
                  pose6(poseError(e->T_cam_lidar, T_reference)).c_str());
      if (e->stereo_estimated)
        std::printf("T_right_left against %s: %s\n", reference.c_str(),
                    pose6(poseError(e->T_right_left, T_reference_stereo)).c_str());
    }
    const std::string quality =
        printQuality(window_keyframes, initial_rig, e->T_cam_lidar, e->T_right_left);
    // The result files first: an overlay that cannot be written must not cost them.
    if (!args.out.empty()) {
      std::string msg;
      if (!writeCalibrationFiles(args.out, calibrator->rig(), *e, frames(args), &msg) ||
          !appendToResultYaml(args.out, quality)) {
        std::cerr << "tescalib_calibrate: " << (msg.empty() ? args.out + ": not written" : msg)
                  << "\n";
        return 1;
      }
      std::printf("%s\n", msg.c_str());
    }
    if (!args.overlay.empty() &&
        !writeOverlay(args.overlay, e->T_cam_lidar,
                      "estimate from " + std::to_string(e->keyframes_used) + " keyframes"))
      return 1;
    return 0;
  }
};

/// The extrinsics of --init over the rig's: a result file (BASE.yaml) or a KITTI calib.txt (e.g.
/// BASE_calib.txt), whose intrinsics are not used.
void applyInit(const std::string& path, StereoRig* rig) {
  if (path.size() > 5 && path.compare(path.size() - 5, 5, ".yaml") == 0) {
    const CalibrationFile init = readCalibrationYaml(path);
    rig->T_cam_lidar = init.T_cam_lidar;
    rig->T_right_left = init.T_right_left;
    return;
  }
  const StereoRig init = readCheckedOdometryRig(path);
  if (std::fabs(init.left.fx - rig->left.fx) > 1e-3)
    std::printf("note: %s has fx %.3f, the data %.3f: only its extrinsics are used\n", path.c_str(),
                init.left.fx, rig->left.fx);
  rig->T_cam_lidar = init.T_cam_lidar;
  rig->T_right_left = init.T_right_left;
}

/// KITTI-layout folders: their keyframes, sequence after sequence (1 s apart); with `take`, only
/// the keyframes it accepts (numbered from 0 over all sequences).
void runSequences(const Args& args, Session* session,
                  const std::function<bool(int)>& take = nullptr) {
  const auto seqs = openSequences(args.sequences);
  StereoRig rig = seqs.front()->rig();
  if (!args.init.empty()) applyInit(args.init, &rig);
  session->settings.deskew = args.deskew < 0 ? seqs.front()->sweptScans() : args.deskew > 0;
  session->start(rig, args, std::to_string(seqs.size()) + " sequence(s)");
  double offset = 0;
  int number = 0;
  for (const auto& seq : seqs) {
    double last = offset;
    for (size_t i : seq->keyframes(session->settings.keyframe_min_dt)) {
      if (take && !take(number++)) continue;
      const std::string label = seq->dir() + " frame " + std::to_string(seq->frameId(i));
      Frame frame;
      try {
        frame = seq->load(i);
        if (session->settings.deskew) {
          if (i == 0) {
            std::printf("  %s: no earlier scan to de-skew with, skipped\n", label.c_str());
            continue;
          }
          session->calibrator->setPreviousScan(std::make_shared<LidarScan>(seq->loadScan(i - 1)),
                                               seq->stamp(i - 1) + offset);
        }
      } catch (const DataError& e) {
        std::printf("  %s: %s\n", label.c_str(), e.what());
        ++session->rejected;
        continue;
      }
      frame.stamp += offset;
      last = frame.stamp;
      session->add(frame, frame.stamp, label);
    }
    offset = last + 1.0;
  }
}

/// The bag's point cloud, image and camera_info topics with their types, for error messages.
std::string bagSensorTopics(const std::string& path) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  std::set<std::string> listed;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    const std::string& type = c->datatype;
    if (type == "sensor_msgs/PointCloud2" || type == "sensor_msgs/Image" ||
        type == "sensor_msgs/CameraInfo")
      listed.insert(c->topic + " (" + type.substr(type.find('/') + 1) + ")");
  }
  std::string out;
  for (const auto& t : listed) out += (out.empty() ? "" : ", ") + t;
  return out.empty() ? "no PointCloud2, Image or CameraInfo topic" : out;
}

/// A rosbag's synchronized sets in order, through the node's FrameIntake: the same keyframe
/// pre-selection and checks as the node's sync callback (non-candidates are skipped; with
/// de-skewing their scans are kept for the next candidate).
struct BagRun {
  const Args& args;
  Session* session;
  tf2::BufferCore tf;
  std::unique_ptr<FrameIntake> intake;
  bool camera_info_change_said = false, ring_recovery_said = false;

  BagRun(const Args& a, Session* s) : args(a), session(s) { readBagStaticTf(args.bag, &tf); }

  void onSet(const BagSet& set) {
    const double stamp = set.left->header.stamp.toSec();
    char label[64];
    std::snprintf(label, sizeof label, "set at %.2f s", stamp);
    if (!session->calibrator) start(set);
    IntakeResult r =
        intake->take(*set.cloud, *set.left, *set.left_info, *set.right, *set.right_info);
    sayObservations(r, label);
    if (r.refused()) {
      std::printf("  %s: %s\n", label, r.reason.c_str());
      ++session->rejected;
      return;
    }
    if (r.outcome == IntakeOutcome::kCandidate) session->add(r.candidate, label);
  }

  /// The first set: the rig from its camera_infos, the initial extrinsic from /tf_static (or
  /// --init), and what its clouds say about de-skewing.
  void start(const BagSet& set) {
    std::string error;
    StereoRig rig;
    if (!ros_conv::stereoFromCameraInfo(*set.left_info, *set.right_info, args.init.empty(), &rig,
                                        &error))
      throw DataError(args.bag + ": " + error);
    if (!args.init.empty())
      applyInit(args.init, &rig);
    else
      rig.T_cam_lidar = bagLidarExtrinsic(args.bag, tf, set, "; give --init FILE");
    session->start(rig, args, "bag " + args.bag);
    intake = std::make_unique<FrameIntake>(session->settings, NodeParams().max_stereo_skew);
    intake->start(*set.left_info, *set.right_info);
    if (!set.cloud->header.frame_id.empty()) session->lidar_frame = set.cloud->header.frame_id;
    const std::string time_field = ros_conv::perPointTimeField(*set.cloud);
    if (!time_field.empty() && !session->settings.deskew)
      std::printf(
          "note: the clouds have a per-point time field ('%s'): raw sweeps, which the "
          "vehicle's motion skews; --deskew 1 unless the driver compensated them\n",
          time_field.c_str());
    if (time_field.empty() && session->settings.deskew)
      std::printf(
          "note: the clouds have no per-point time field: de-skewed by azimuth, which is right "
          "only for a LiDAR phase-locked to the cameras that faces its +x at every image stamp "
          "(KITTI's); --deskew 0 otherwise\n");
  }

  /// The intake's observations, each said once: a camera_info that changed, the ring count,
  /// rings recovered from scan order.
  void sayObservations(const IntakeResult& r, const char* label) {
    if (r.camera_info_changed && !camera_info_change_said) {
      camera_info_change_said = true;
      std::printf(
          "  %s: camera_info changed since the first set (P, size, binning or ROI): the "
          "intrinsics and baseline of the first set are kept\n",
          label);
    }
    if (r.rings >= 0 && r.rings < 64) std::printf("note: %s\n", ringCountNote(r.rings).c_str());
    if (r.ring_recovered && !ring_recovery_said) {
      ring_recovery_said = true;
      std::printf(
          "note: the point clouds have no 'ring' field; rings recovered from scan order "
          "(KITTI-style clouds)\n");
    }
  }
};

void runBag(const Args& args, Session* session) {
  BagRun run(args, session);
  const BagCounts n =
      readBagSets(args.bag, args.topics, [&run](const BagSet& set) { run.onSet(set); });
  if (n.sets == 0)
    throw DataError(args.bag + ": no synchronized sets (" + std::to_string(n.clouds) +
                    " clouds on " + args.topics.points + ", " + std::to_string(n.left) +
                    " images on " + args.topics.left + ", " + std::to_string(n.right) + " on " +
                    args.topics.right + "; camera_info on " + args.topics.left_info + " and " +
                    args.topics.right_info +
                    "): check --points, --left, --right (the image topics themselves, camera_info "
                    "is read beside them), --max-skew; the bag has " +
                    bagSensorTopics(args.bag));
  std::printf(
      "bag: %d clouds, %d left and %d right images, %d synchronized sets, %d clouds "
      "without images within %.3f s\n",
      n.clouds, n.left, n.right, n.sets, n.unmatched_clouds, args.topics.max_skew);
}

/// The session's settings from the command line.
void configure(const Args& args, Session* session) {
  session->settings.estimate_stereo = args.mode == "co" || args.mode == "joint";
  session->settings.joint = args.mode == "joint";
  session->settings.window_size = windowSize(args);
  if (args.min_keyframes) session->settings.min_keyframes = *args.min_keyframes;
  session->settings.keyframe.mesh.consistent_sample = args.consistent_sample;
  session->settings.deskew = args.deskew > 0;
  if (args.search_deg >= 0) session->settings.co.lidar.search_step_deg = args.search_deg;
  session->settings.monitor.action = args.monitor;
  session->keep_last_keyframe = !args.overlay.empty();
}

/// --split K: the keyframes in K contiguous parts, each calibrated by a session of its own, then
/// their estimates against each other. 0 when at least two parts converged.
int runSplit(const Args& args) {
  const OnlineSettings defaults;
  int total = 0;
  for (const auto& seq : openSequences(args.sequences))
    total += static_cast<int>(seq->keyframes(defaults.keyframe_min_dt).size());
  std::vector<calibrate::SplitWindow> windows(args.split);
  int converged = 0;
  for (int k = 0; k < args.split; ++k) {
    const int first = k * total / args.split, end = (k + 1) * total / args.split;
    std::printf("\n=== window %d of %d: keyframes %d-%d of %d ===\n", k + 1, args.split, first + 1,
                end, total);
    Session session;
    configure(args, &session);
    runSequences(args, &session, [first, end](int n) { return n >= first && n < end; });
    session.finish();
    calibrate::SplitWindow& w = windows[k];
    w.keyframes = std::to_string(first + 1) + "-" + std::to_string(end);
    const auto e = session.calibrator->estimate();
    const auto last = session.calibrator->lastSolve();
    w.converged = e.has_value();
    w.solved = e || last;
    if (w.solved) w.estimate = e ? *e : *last;
    converged += w.converged;
    session.report(args, 0);
  }
  calibrate::printRepeatability(windows);
  return converged >= 2 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!calibrate::parse(argc, argv,
                        &args)) {  // the reason is on stderr; the usage would scroll it away
    std::cerr << "tescalib_calibrate: --help lists the options\n";
    return 2;
  }
  Session session;
  configure(args, &session);
  const auto t_start = std::chrono::steady_clock::now();
  try {
    if (args.split > 0) return runSplit(args);
    if (args.bag.empty())
      runSequences(args, &session);
    else
      runBag(args, &session);
  } catch (const DataError& e) {
    std::cerr << "tescalib_calibrate: " << e.what() << "\n";
    return 1;
  }
  session.finish();  // a solve never throws (it turns solver errors into a failed solve)
  session.monitor.printSummary();
  std::string json_error;
  if (!args.json.empty() && !session.monitor.writeJson(args.json, &json_error)) {
    std::cerr << "tescalib_calibrate: " << json_error << "\n";
    return 1;
  }
  return session.report(
      args, std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
}
