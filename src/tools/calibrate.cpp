// tescalib_calibrate: calibrates a recording offline, without ROS. It feeds the keyframes of
// KITTI-layout folders (odometry or raw layout, or tescalib_simulate output) through the same
// OnlineCalibrator the nodelet runs, from the folders' own calibration (or --init FILE) as the
// initial guess, prints every estimate the node would publish, and writes the last one as the
// node's ~save service does (BASE.yaml, BASE_calib.txt, BASE_static_tf.launch).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tescalib/core/calibration_io.h"
#include "tescalib/core/error.h"
#include "tescalib/core/geometry.h"
#include "tescalib/core/kitti_reader.h"
#include "tescalib/core/online_calibrator.h"

#include "cli.h"

using namespace tescalib;

namespace {

struct Args {
  std::vector<std::string> sequences;
  std::string mode = "lidar_stereo";
  int window = 0;  // 0: 20 keyframes (lidar_stereo), 10 (co, the paper's batch)
  std::string init;
  double perturb_rot_deg = 0, perturb_trans_m = 0;
  unsigned seed = 1;
  int deskew = -1;  // -1: as the data say (KittiSequence::sweptScans)
  std::string out;
  std::string lidar_frame = "velo_link";
};

void usage() {
  std::cout
      << "usage: rosrun tescalib tescalib_calibrate --sequences DIR[,DIR...] [--mode "
         "lidar_stereo|co]\n"
         "       [--window N] [--init CALIB.txt] [--perturb-rot-deg R --perturb-trans-m T "
         "[--seed S]]\n"
         "       [--deskew 0|1] [--out BASE [--lidar-frame NAME]]\n"
         "Calibrates the recording in DIR (KITTI odometry or raw layout; several folders of one\n"
         "rig are played one after the other) with the online pipeline, without ROS.\n"
         "--mode lidar_stereo: T_cam_lidar only (the stereo pair as calibrated); co: both\n"
         "  extrinsics (co-calibration).\n"
         "--window N: keyframes in the sliding window (default 20; co: 10).\n"
         "--init FILE: initial extrinsics from a KITTI calib.txt (e.g. an earlier "
         "BASE_calib.txt);\n"
         "  intrinsics stay those of DIR. Default: DIR's own calibration.\n"
         "--perturb-rot-deg / --perturb-trans-m: start that far from the initial T_cam_lidar\n"
         "  (random direction, --seed); the errors against DIR's calibration are then printed.\n"
         "--deskew: motion-compensate the scans (default: for raw recordings and swept\n"
         "  generated scans).\n"
         "--out BASE: write the last converged estimate to BASE.yaml, BASE_calib.txt and\n"
         "  BASE_static_tf.launch (nothing is written when none converged); --lidar-frame:\n"
         "  the LiDAR's tf frame in them (default velo_link, as kitti2bag; the cameras are\n"
         "  tescalib_left and tescalib_right, as the node publishes them).\n"
         "Exit status: 0 when an estimate converged, 1 when none did or the data are unusable,\n"
         "2 on a usage error.\n";
}

bool parse(int argc, char** argv, Args* a) {
  auto option = [a](const std::string& k, const std::string& v) {
    if (k == "--sequences")
      a->sequences = cli::splitList(v);
    else if (k == "--mode")
      a->mode = v;
    else if (k == "--window")
      a->window = std::stoi(v);
    else if (k == "--init")
      a->init = v;
    else if (k == "--perturb-rot-deg")
      a->perturb_rot_deg = std::stod(v);
    else if (k == "--perturb-trans-m")
      a->perturb_trans_m = std::stod(v);
    else if (k == "--seed")
      a->seed = static_cast<unsigned>(std::stoul(v));
    else if (k == "--deskew")
      a->deskew = std::stoi(v);
    else if (k == "--out")
      a->out = v;
    else if (k == "--lidar-frame")
      a->lidar_frame = v;
    else
      return false;
    return true;
  };
  if (!cli::parseOptions(argc, argv, "tescalib_calibrate", usage, option)) return false;
  if (a->sequences.empty()) {
    std::cerr << "tescalib_calibrate: --sequences is required\n";
    return false;
  }
  if (a->mode != "lidar_stereo" && a->mode != "co") {
    std::cerr << "tescalib_calibrate: --mode must be lidar_stereo or co\n";
    return false;
  }
  if (a->window < 0 || a->window == 1 || a->window == 2) {
    std::cerr << "tescalib_calibrate: --window must be at least 3\n";
    return false;
  }
  if (a->perturb_rot_deg < 0 || a->perturb_trans_m < 0) {
    std::cerr << "tescalib_calibrate: perturbations are sizes (>= 0)\n";
    return false;
  }
  return true;
}

/// "rx ry rz deg, tx ty tz cm" of a 6-vector [phi (rad); tau (m)].
std::string pose6(const Vector6d& v) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[%+.4f %+.4f %+.4f] deg, [%+.2f %+.2f %+.2f] cm",
                v(0) * kDegPerRad, v(1) * kDegPerRad, v(2) * kDegPerRad, 100 * v(3), 100 * v(4),
                100 * v(5));
  return buf;
}

std::string sigma6(const Matrix6d& cov) {
  Vector6d s;
  for (int i = 0; i < 6; ++i) s(i) = std::sqrt(std::max(0.0, cov(i, i)));
  std::string out = pose6(s);
  for (char& c : out)
    if (c == '+') c = ' ';
  return out;
}

std::string trusted(const bool observable[6]) {
  static const char* kAxis[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  std::string weak;
  for (int i = 0; i < 6; ++i)
    if (!observable[i]) weak += std::string(weak.empty() ? "" : " ") + kAxis[i];
  return weak.empty() ? "every axis trusted" : "not trusted: " + weak;
}

void printExtrinsic(const char* name, const Eigen::Isometry3d& T, const Matrix6d& cov,
                    const bool observable[6]) {
  const Eigen::Vector3d r = logSO3(T.linear()) * kDegPerRad;
  const Eigen::Vector3d& t = T.translation();
  std::printf("%s: rotation vector [%+.4f %+.4f %+.4f] deg, translation [%+.4f %+.4f %+.4f] m\n",
              name, r.x(), r.y(), r.z(), t.x(), t.y(), t.z());
  std::printf("  sigma %s; %s\n", sigma6(cov).c_str(), trusted(observable).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parse(argc, argv, &args)) {
    usage();
    return 2;
  }
  std::vector<std::unique_ptr<KittiSequence>> seqs;
  StereoRig rig;
  try {
    seqs = openSequences(args.sequences);
    rig = seqs.front()->rig();
    if (!args.init.empty()) {
      const StereoRig init = rigFromOdometryCalib(readKittiOdometryCalib(args.init));
      if (std::fabs(init.left.fx - rig.left.fx) > 1e-3)
        std::printf("note: %s has fx %.3f, the data %.3f: only its extrinsics are used\n",
                    args.init.c_str(), init.left.fx, rig.left.fx);
      rig.T_cam_lidar = init.T_cam_lidar;
      rig.T_right_left = init.T_right_left;
    }
  } catch (const DataError& e) {
    std::cerr << "tescalib_calibrate: " << e.what() << "\n";
    return 1;
  }
  // The errors' reference with --perturb (the stereo pair is not perturbed).
  const Eigen::Isometry3d T_reference = rig.T_cam_lidar, T_reference_stereo = rig.T_right_left;
  const bool perturbed = args.perturb_rot_deg > 0 || args.perturb_trans_m > 0;
  if (perturbed) {
    std::mt19937_64 rng(args.seed);
    rig.T_cam_lidar = perturb(rig.T_cam_lidar, randomPerturbation(args.perturb_rot_deg / kDegPerRad,
                                                                  args.perturb_trans_m, rng));
  }

  OnlineSettings settings;
  settings.estimate_stereo = args.mode == "co";
  settings.window_size = args.window > 0 ? args.window : (settings.estimate_stereo ? 10 : 20);
  settings.deskew = args.deskew < 0 ? seqs.front()->sweptScans() : args.deskew > 0;
  std::printf(
      "tescalib_calibrate: %zu sequence(s), mode %s, window %d, %dx%d, fx %.2f, baseline "
      "%.4f m\n",
      seqs.size(), args.mode.c_str(), settings.window_size, rig.left.width, rig.left.height,
      rig.left.fx, rig.baseline());
  if (perturbed)
    std::printf("initial T_cam_lidar %s from the data's calibration\n",
                pose6(poseError(rig.T_cam_lidar, T_reference)).c_str());

  OnlineCalibrator calibrator(rig, settings);
  const auto t_start = std::chrono::steady_clock::now();
  double offset = 0;  // stamps of later sequences follow the earlier ones (1 s apart)
  int keyframes = 0, rejected = 0, solves = 0, published = 0;
  std::string last_solve;
  for (const auto& seq : seqs) {
    double last = offset;
    for (size_t i : seq->keyframes(settings.keyframe_min_dt)) {
      Frame frame;
      try {
        frame = seq->load(i);
        if (settings.deskew) {
          if (i == 0) {
            std::printf("  %s frame %d: no earlier scan to de-skew with, skipped\n",
                        seq->dir().c_str(), seq->frameId(i));
            continue;
          }
          calibrator.setPreviousScan(std::make_shared<LidarScan>(seq->loadScan(i - 1)),
                                     seq->stamp(i - 1) + offset);
        }
      } catch (const DataError& e) {
        std::printf("  %s frame %d: %s\n", seq->dir().c_str(), seq->frameId(i), e.what());
        ++rejected;
        continue;
      }
      frame.stamp += offset;
      last = frame.stamp;
      std::string msg;
      const FrameResult r = calibrator.addFrame(frame, frame.stamp, &msg);
      if (r == FrameResult::kRejected) {
        std::printf("  %s frame %d rejected: %s\n", seq->dir().c_str(), seq->frameId(i),
                    msg.c_str());
        ++rejected;
        continue;
      }
      if (r != FrameResult::kKeyframe) continue;
      ++keyframes;
      if (!msg.empty())
        std::printf("  %s frame %d: %s\n", seq->dir().c_str(), seq->frameId(i), msg.c_str());
      if (!calibrator.readyToSolve()) continue;
      const bool changed = calibrator.solve(&last_solve);
      ++solves;
      const auto e = calibrator.estimate();
      std::printf("  keyframe %d (%s frame %d): ", keyframes, seq->dir().c_str(), seq->frameId(i));
      if (!changed) std::printf("%s", last_solve.c_str());
      if (changed && e) {
        std::printf("new estimate");
        ++published;
        if (perturbed)
          std::printf(", error %s", pose6(poseError(e->T_cam_lidar, T_reference)).c_str());
        std::printf(", %.2f s", e->solve_seconds);
      }
      std::printf("\n");
    }
    offset = last + 1.0;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::printf("%d keyframes, %d rejected, %d solves, %d estimates, %.1f s\n", keyframes, rejected,
              solves, published, seconds);

  const auto e = calibrator.estimate();
  if (!e) {
    std::printf("no converged estimate%s%s\n", last_solve.empty() ? "" : ": ", last_solve.c_str());
    if (keyframes < settings.minKeyframes())
      std::printf("(%d keyframes; a solve needs %d)\n", keyframes, settings.minKeyframes());
    if (const auto c = calibrator.lastSolve()) {
      // What the window gives, untrusted: for a look, not for use (nothing is written).
      std::printf("the last solve's result, not trusted (%d keyframes):\n", c->keyframes_used);
      printExtrinsic("T_cam_lidar", c->T_cam_lidar, c->cov_lidar, c->observable_lidar);
      if (c->stereo_estimated)
        printExtrinsic("T_right_left", c->T_right_left, c->cov_stereo, c->observable_stereo);
      std::printf("change from the initial guess: %s\n",
                  pose6(poseError(c->T_cam_lidar, rig.T_cam_lidar)).c_str());
    }
    return 1;
  }
  std::printf("estimate from %d keyframes:\n", e->keyframes_used);
  printExtrinsic("T_cam_lidar", e->T_cam_lidar, e->cov_lidar, e->observable_lidar);
  if (e->stereo_estimated)
    printExtrinsic("T_right_left", e->T_right_left, e->cov_stereo, e->observable_stereo);
  else
    std::printf("T_right_left: as calibrated (not estimated; --mode co estimates it)\n");
  std::printf("change from the initial guess: %s\n",
              pose6(poseError(e->T_cam_lidar, rig.T_cam_lidar)).c_str());
  if (perturbed) {
    std::printf("error against the data's calibration: %s\n",
                pose6(poseError(e->T_cam_lidar, T_reference)).c_str());
    if (e->stereo_estimated)
      std::printf("T_right_left against the data's calibration: %s\n",
                  pose6(poseError(e->T_right_left, T_reference_stereo)).c_str());
  }
  if (!args.out.empty()) {
    std::string msg;
    CalibrationFrames frames;
    frames.lidar = args.lidar_frame;
    if (!writeCalibrationFiles(args.out, calibrator.rig(), *e, frames, &msg)) {
      std::cerr << "tescalib_calibrate: " << msg << "\n";
      return 1;
    }
    std::printf("%s\n", msg.c_str());
  }
  return 0;
}
