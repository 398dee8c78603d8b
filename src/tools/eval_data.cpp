#include "eval_data.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/io/kitti_calib.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/core/solvers/co_calibration.h"
#include "tescalib/core/stereo/row_alignment.h"

namespace tescalib::eval {

using Clock = std::chrono::steady_clock;

namespace {

/// The sequences' keyframes: (sequence, frame index) of those the windows use.
using Picked = std::vector<std::pair<size_t, size_t>>;

/// Opens the sequences and picks the windows' keyframes: the first W, or with --windows disjoint
/// as many whole windows of W as there are.
bool pickKeyframes(const Args& args, std::vector<std::unique_ptr<KittiSequence>>* seqs,
                   Picked* picked, EvalData* d) {
  try {
    *seqs = openSequences(args.sequences);
    for (size_t si = 0; si < seqs->size(); ++si)
      for (size_t i : (*seqs)[si]->keyframes(0.5)) {
        ++d->available;
        if (args.windows == "disjoint" || static_cast<int>(picked->size()) < args.window)
          picked->emplace_back(si, i);
      }
  } catch (const DataError& e) {
    std::cerr << "tescalib_eval: " << e.what() << "\n";
    return false;
  }
  d->rig = seqs->front()->rig();
  d->truth = d->rig;
  const std::string true_calib = seqs->front()->dir() + "/calib_true.txt";
  if (std::ifstream(true_calib).good()) {
    try {
      d->truth.T_right_left = readCheckedOdometryRig(true_calib).T_right_left;
    } catch (const DataError& e) {
      std::cerr << "tescalib_eval: " << e.what() << "\n";
      return false;
    }
    std::cout << "tescalib_eval: the true right camera is " << true_calib << "'s (the data are "
              << "rectified with calib.txt's)\n";
  }
  d->window_size = args.windows == "disjoint" ? static_cast<size_t>(args.window) : picked->size();
  d->n_windows = d->window_size > 0 ? picked->size() / d->window_size : 0;
  if (d->n_windows == 0) {
    std::cerr << "tescalib_eval: not enough keyframes (" << picked->size() << ") for one window of "
              << d->window_size << "\n";
    return false;
  }
  picked->resize(d->n_windows * d->window_size);
  std::cout << "tescalib_eval: mode " << args.mode << ", method " << args.method << ", "
            << picked->size() << " of the " << d->available << " keyframes of " << seqs->size()
            << " sequence(s), " << d->n_windows << " window(s) of " << d->window_size << ", "
            << args.trials << " trials, init " << args.init_rot_deg << " deg / "
            << args.init_trans_m << " m, seed " << args.seed << "\n";
  return true;
}

/// The keyframes' settings: the meshes' faces and the stereo clouds' refinement rounds.
void setKeyframeSettings(const Args& args, EvalData* d) {
  d->kfs = KeyframeSettings{};
  // The joint problem's photometric residuals intersect rays with any key point's face along its
  // normal: it needs every face's normal fitted, not only the solvers' sample (held-out starts:
  // 81.5 % with every face fitted, 72.2 % with the sample).
  if (args.mode == "joint") d->kfs.mesh.sampled_faces = 0;
  d->kfs.mesh.consistent_sample = args.consistent_sample;
  // The command line's refinement rounds, over the LiDAR-stereo clouds' default and over the one
  // co / joint match their clouds with (co-calibration's own: one exact round).
  auto withRefineArgs = [&](DisparityRefinementSettings r) {
    if (args.refine_iterations >= 0) r.iterations = args.refine_iterations;
    if (args.refine_smoothed >= 0) r.smoothed_gradient_rounds = args.refine_smoothed;
    return r;
  };
  d->kfs.stereo.refinement = withRefineArgs(d->kfs.stereo.refinement);
  d->kfs.stereo.sgbm_paths = args.sgbm_paths;
  d->kfs.stereo.sgbm_both_ways = args.sgbm_both_ways;
  if (args.rectified_vertical_blur >= 0)
    d->kfs.stereo.rectified_vertical_blur_px = args.rectified_vertical_blur;
  d->co_refinement = withRefineArgs(CoCalibrationSettings{}.stereo_cloud.refinement);
  const bool co_clouds = args.mode == "co" || args.mode == "joint";
  d->used_refinement = co_clouds ? d->co_refinement : d->kfs.stereo.refinement;
  if (args.mode != "stereo")  // stereo mode matches no clouds
    std::cout << "  stereo clouds: SGBM with " << args.sgbm_paths << " paths"
              << (args.sgbm_both_ways ? " both ways" : "")
              << ", re-rectified keyframe pairs low-passed along the columns by "
              << d->kfs.stereo.rectified_vertical_blur_px << " px, disparity refinement "
              << d->used_refinement.iterations << " round(s), "
              << d->used_refinement.smoothed_gradient_rounds
              << " of them with the smoothed gradient\n";
}

/// De-skews keyframe `index`'s scan (frame `fi` of `seq`) with constant velocity from this scan
/// to the next frame's (or from the previous one's).
void deskewKeyframe(const KittiSequence& seq, size_t fi, size_t index, Frame* frame) {
  if (seq.size() < 2) throw DataError(seq.dir() + ": --deskew needs two frames");
  const size_t j = fi + 1 < seq.size() ? fi + 1 : fi - 1;
  const LidarScan other = seq.loadScan(j);
  const auto t_dk = std::chrono::steady_clock::now();
  const ScanMotion m = j > fi
                           ? estimateScanMotion(frame->scan, other, seq.stamp(j) - seq.stamp(fi))
                           : estimateScanMotion(other, frame->scan, seq.stamp(fi) - seq.stamp(j));
  const double s_dk =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_dk).count();
  if (m.valid)
    std::printf(
        "  keyframe %zu: de-skewed, %.2f m/s, %.2f deg/s (registered with frame %d, "
        "RMS %.3f m, %.2f s)\n",
        index, m.velocity.norm(), m.angular_velocity.norm() * kDegPerRad, seq.frameId(j), m.rms_m,
        s_dk);
  else
    std::printf("  keyframe %zu: not de-skewed: %s\n", index, m.message.c_str());
  deskewScan(&frame->scan, m);  // Velodyne: clockwise, 10 Hz, triggered forward
}

/// Loads the picked frames into `frames` and the keyframes (de-skewed, thinned to --keep-rings,
/// grey images).
bool loadKeyframes(const Args& args, const std::vector<std::unique_ptr<KittiSequence>>& seqs,
                   const Picked& picked, std::vector<Frame>* frames, EvalData* d) {
  try {
    for (const auto& [si, fi] : picked) {
      frames->push_back(seqs[si]->load(fi));
      if (args.deskew > 0 || (args.deskew < 0 && seqs[si]->sweptScans()))
        deskewKeyframe(*seqs[si], fi, frames->size() - 1, &frames->back());
      keepEveryNthRing(&frames->back().scan, args.keep_rings);
      Keyframe kf;
      kf.stamp = frames->back().stamp;
      kf.scan = frames->back().scan;
      cv::cvtColor(frames->back().left, kf.left_gray, cv::COLOR_BGR2GRAY);
      cv::cvtColor(frames->back().right, kf.right_gray, cv::COLOR_BGR2GRAY);
      d->keyframes.push_back(std::move(kf));
    }
  } catch (const DataError& e) {
    std::cerr << "tescalib_eval: " << e.what() << "\n";
    return false;
  }
  return true;
}

/// lidar_stereo mode: the keyframes' stereo clouds at the ground truth, one keyframe per core at a
/// time (as a window is preprocessed in a batch); the time charged to each window is its share of
/// the wall-clock time.
void computeStereoClouds(const std::vector<Frame>& frames, const Eigen::Isometry3d& T_right_left,
                         EvalData* d) {
  const auto t_stereo = Clock::now();
  parallelFor(static_cast<int>(d->keyframes.size()), resolveThreads(d->kfs.stereo.threads),
              [&](int k) {
                d->keyframes[k].stereo = computeStereoCloud(frames[k].left, frames[k].right, d->rig,
                                                            T_right_left, d->kfs.stereo);
                d->keyframes[k].T_right_left_used = T_right_left;
              });
  d->stereo_seconds = std::chrono::duration<double>(Clock::now() - t_stereo).count();
  for (size_t k = 0; k < d->keyframes.size(); ++k) {
    d->kf_stereo_seconds.push_back(d->stereo_seconds / d->keyframes.size());
    const cv::Mat& disp = d->keyframes[k].stereo.disparity;
    const double valid = double(cv::countNonZero(disp == disp)) / disp.total();  // NaN != NaN
    std::printf("  keyframe %zu: %zu stereo points, %.0f %% valid disparity, SGBM %.3f s\n", k,
                d->keyframes[k].stereo.points.size(), 100 * valid,
                d->keyframes[k].stereo.seconds_sgbm);
  }
}

/// --align-rows: the extrinsic that aligns the rows of keyframe 0's pair as the calibration
/// predicts them (rowAlignedExtrinsic), and those rows in `rows` (measured on the pair's cloud at
/// the calibration); the calibration itself when that moves no row by more than the node's
/// stereo/align_rows_min_px.
Eigen::Isometry3d rowAlignedPair(const std::vector<Frame>& frames, const EvalData& d,
                                 VerticalAlignment* rows) {
  const StereoCloud cloud =
      computeStereoCloud(frames[0].left, frames[0].right, d.rig, d.rig.T_right_left, d.kfs.stereo);
  *rows = verticalAlignment(frames[0].left, frames[0].right, cloud, d.rig, d.rig.T_right_left);
  if (!(largestRowCorrectionPx(*rows, d.rig.left) > OnlineSettings{}.align_rows_min_px))
    return d.rig.T_right_left;
  return rowAlignedExtrinsic(d.rig.T_right_left, *rows, d.rig.right.fy);
}

/// The rows of keyframe 0 before (`rows`) and in the clouds computed with the aligned `T`.
void printAlignedRows(const std::vector<Frame>& frames, const EvalData& d,
                      const VerticalAlignment& rows, const Eigen::Isometry3d& T) {
  const VerticalAlignment after =
      verticalAlignment(frames[0].left, frames[0].right, d.keyframes[0].stereo, d.rig, T);
  std::printf(
      "  rows of keyframe 0: offset %+.3f px, roll slope %+.3f px (%d corners); "
      "re-rectified: %+.3f px, %+.3f px\n",
      rows.offset_px, rows.slope_x_px, rows.points, after.offset_px, after.slope_x_px);
}

}  // namespace

bool loadData(const Args& args, EvalData* d) {
  std::vector<std::unique_ptr<KittiSequence>> seqs;
  Picked picked;
  if (!pickKeyframes(args, &seqs, &picked, d)) return false;
  // Stereo clouds do not depend on the LiDAR extrinsic: computed once (stereo fixed at the
  // ground truth in lidar_stereo mode). Meshes depend on the view filter of the initial guess and
  // are rebuilt per trial.
  setKeyframeSettings(args, d);
  std::vector<Frame> frames;
  if (!loadKeyframes(args, seqs, picked, &frames, d)) return false;
  // stereo: no cloud needed; co: computed per trial
  if (args.mode == "lidar_stereo") {
    VerticalAlignment rows;
    const Eigen::Isometry3d T =
        args.align_rows > 0 ? rowAlignedPair(frames, *d, &rows) : d->rig.T_right_left;
    computeStereoClouds(frames, T, d);
    if (args.align_rows > 0) printAlignedRows(frames, *d, rows, T);
  }
  return true;
}

}  // namespace tescalib::eval
