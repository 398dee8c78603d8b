// tescalib_calibrate's session: the online calibrator the node runs, fed with a recording's
// frames, solving after each new keyframe as the node does, printing what happened to each
// keyframe and the final estimate, and writing the result files.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/allocator.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/overlay.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/core/uncertainty/trust.h"

#include "calibrate_args.h"
#include "calibrate_holdout.h"
#include "calibrate_monitor.h"
#include "calibrate_print.h"
#include "calibrate_quality.h"

namespace tescalib::calibrate {

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

  int holdout = 0;                         // --holdout N
  int keyframe_candidates = 0;             // keyframes offered, held out or not
  std::vector<Frame> held_out;             // --holdout's keyframes, not calibrated on
  std::optional<StereoRig> recording_rig;  // the data's own calibration, when known

  /// --holdout: whether the next keyframe is held out (kept for the held-out scores, printed).
  bool holdBack(const Frame& frame, const std::string& label) {
    if (!heldOut(keyframe_candidates++, holdout)) return false;
    held_out.push_back(frame);
    std::printf("  %s: held out (--holdout %d)\n", label.c_str(), holdout);
    return true;
  }

  /// --holdout's scores of `T_cam_lidar` / `T_right_left` (an estimate or the last solve), the
  /// initial guess and the recording's calibration; the block for BASE.yaml's quality:.
  std::string printHeldOutScores(const Eigen::Isometry3d& T_cam_lidar,
                                 const Eigen::Isometry3d& T_right_left) const {
    if (holdout < 2) return "";
    if (held_out.empty()) {
      std::printf("held-out scores: no keyframe was held out (--holdout %d)\n", holdout);
      return "";
    }
    std::vector<HeldOutCalibration> c = {{"estimate", T_cam_lidar, T_right_left},
                                         {"initial_guess", T_initial, initial_rig.T_right_left}};
    if (recording_rig && (!recording_rig->T_cam_lidar.isApprox(T_initial, 1e-12) ||
                          !recording_rig->T_right_left.isApprox(initial_rig.T_right_left, 1e-12)))
      c.push_back({"recording", recording_rig->T_cam_lidar, recording_rig->T_right_left});
    else if (recording_rig)
      std::printf("(the initial guess is the recording's calibration)\n");
    return printHeldOut(held_out, holdout, initial_rig, c);
  }

  /// The rig with its initial extrinsics; with --perturb-*, T_cam_lidar is moved away from them
  /// (they stay the reference of the printed errors).
  void start(StereoRig rig, const Args& args, const std::string& source) {
    T_reference = rig.T_cam_lidar;
    T_reference_stereo = rig.T_right_left;
    if (!args.init.empty() || !args.init_pose.empty()) reference = "the --init calibration";
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
    returnFreeMemoryAfterKeyframe(++keyframes);
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
    const CameraIntrinsics cam = calibrator->rig().left;
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
    ExtrinsicReport r = extrinsicReport(
        {"LiDAR -> left camera", f.lidar, f.left, e.T_cam_lidar, e.cov_lidar}, e.cov_lidar_known,
        e.observable_lidar, published, settings.co.lidar, e.weakest_lidar);
    r.node_parameter = "initial/T_cam_lidar";
    return r;
  }

  /// T_right_left, as lidarReport.
  ExtrinsicReport stereoReport(const OnlineEstimate& e, const Args& args, bool published) const {
    const CalibrationFrames f = frames(args);
    return extrinsicReport({"left -> right camera", f.left, f.right, e.T_right_left, e.cov_stereo},
                           e.cov_stereo_known, e.observable_stereo, published, settings.co.stereo,
                           e.weakest_stereo);
  }

  /// `r` (title, frames, transform, covariance) with one extrinsic's trust fields and the limits
  /// of the solver settings `solver` (max_sigma_rot_deg, max_sigma_trans_m).
  template <typename SolverSettings>
  static ExtrinsicReport extrinsicReport(ExtrinsicReport r, bool covariance_known,
                                         const bool* observable, bool published,
                                         const SolverSettings& solver,
                                         const WeakDirection& weakest) {
    r.covariance_known = covariance_known;
    r.observable = observable;
    r.published = published;
    r.limit_rot_deg = solver.max_sigma_rot_deg;
    r.limit_trans_m = solver.max_sigma_trans_m;
    r.weakest = weakest;
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
        printHeldOutScores(c->T_cam_lidar, c->T_right_left);
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
    std::string quality =
        printQuality(window_keyframes, initial_rig, e->T_cam_lidar, e->T_right_left);
    if (const std::string h = printHeldOutScores(e->T_cam_lidar, e->T_right_left); !h.empty())
      quality += (quality.empty() ? "quality:\n" : "") + h;
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

}  // namespace tescalib::calibrate
