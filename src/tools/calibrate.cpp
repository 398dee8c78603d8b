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

#include "tescalib/core/common/allocator.h"
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
#include "tescalib/ros/initial_rig.h"
#include "tescalib/ros/params.h"

#include "calibrate_args.h"
#include "calibrate_monitor.h"
#include "calibrate_print.h"
#include "calibrate_quality.h"
#include "calibrate_session.h"
#include "calibrate_split.h"
#include "cli.h"

using namespace tescalib;
using calibrate::appendToResultYaml;
using calibrate::Args;
using calibrate::ExtrinsicReport;
using calibrate::pose6;
using calibrate::printQuality;
using calibrate::Session;
using calibrate::windowSize;

namespace {

/// The extrinsics of --init over the rig's: a result file (BASE.yaml) or a KITTI calib.txt (e.g.
/// BASE_calib.txt), whose intrinsics are not used, or T_cam_lidar alone (x,y,z,qx,qy,qz,qw).
void applyInit(const Args& args, StereoRig* rig) {
  if (!args.init_pose.empty()) {
    rig->T_cam_lidar = fromVector7(args.init_pose);
    return;
  }
  const std::string& path = args.init;
  if (path.empty()) return;
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
  session->recording_rig = rig;
  applyInit(args, &rig);
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
      if (session->holdBack(frame, label)) continue;
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
    if (r.outcome == IntakeOutcome::kCandidate && !session->holdBack(r.candidate.frame, label))
      session->add(r.candidate, label);
  }

  /// The first set: the rig from its camera_infos, the initial extrinsic from /tf_static (or
  /// --init), and what its clouds say about de-skewing.
  void start(const BagSet& set) {
    std::string error;
    StereoRig rig;
    if (!ros_conv::stereoFromCameraInfo(*set.left_info, *set.right_info, args.init.empty(), &rig,
                                        &error))
      throw DataError(args.bag + ": " + error);
    if (!args.init.empty() || !args.init_pose.empty()) {
      session->recording_rig = recordingRig(set);
      applyInit(args, &rig);
    } else {
      rig.T_cam_lidar = bagLidarExtrinsic(args.bag, tf, set, "; give --init FILE or POSE");
      session->recording_rig = rig;
    }
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

  /// With --init: the bag's own calibration (camera_info's pair, /tf_static's LiDAR extrinsic),
  /// for the held-out scores; none when the bag has no LiDAR extrinsic.
  std::optional<StereoRig> recordingRig(const BagSet& set) {
    StereoRig rig;
    std::string error;
    if (!ros_conv::stereoFromCameraInfo(*set.left_info, *set.right_info, true, &rig, &error))
      return std::nullopt;
    try {
      rig.T_cam_lidar = bagLidarExtrinsic(args.bag, tf, set, "");
    } catch (const DataError&) {
      return std::nullopt;
    }
    return rig;
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
  if (n.undecodable_images)
    std::printf("bag: %d compressed images that do not decode left out\n", n.undecodable_images);
}

/// The session's settings from the command line.
void configure(const Args& args, Session* session) {
  session->settings.estimate_stereo = args.mode == "co" || args.mode == "joint";
  session->settings.joint = args.mode == "joint";
  session->settings.window_size = windowSize(args);
  if (args.min_keyframes) session->settings.min_keyframes = *args.min_keyframes;
  session->settings.keyframe.mesh.consistent_sample = args.consistent_sample;
  session->settings.deskew = args.deskew > 0;
  session->settings.align_rows = args.align_rows > 0;
  session->settings.keyframe.stereo.sgbm_paths = args.sgbm_paths;
  session->settings.co.stereo_cloud.sgbm_paths = args.sgbm_paths;
  session->settings.keyframe.stereo.sgbm_both_ways = args.sgbm_both_ways > 0;
  session->settings.co.stereo_cloud.sgbm_both_ways = args.sgbm_both_ways > 0;
  if (args.rectified_vertical_blur >= 0)  // the keyframes' clouds (coStereoCloudSettings)
    session->settings.keyframe.stereo.rectified_vertical_blur_px = args.rectified_vertical_blur;
  if (args.search_deg >= 0) session->settings.co.lidar.search_step_deg = args.search_deg;
  session->settings.monitor.action = args.monitor;
  session->holdout = args.holdout;
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
  keepResidentMemoryFlat();
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
