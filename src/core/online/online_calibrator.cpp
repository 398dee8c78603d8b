#include "tescalib/core/online/online_calibrator.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

#include <Eigen/Eigenvalues>

#include "tescalib/core/common/error.h"
#include "tescalib/core/solvers/joint_calibration.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

OnlineCalibrator::OnlineCalibrator(const StereoRig& rig, const OnlineSettings& settings)
    : rig_(rig), settings_(settings) {}

FrameResult OnlineCalibrator::addFrame(const Frame& frame, double lidar_stamp, std::string* msg,
                                       std::shared_ptr<const Keyframe>* built) {
  msg->clear();
  if (frame.scan.empty()) {
    *msg = "empty LiDAR scan";
    return FrameResult::kRejected;
  }
  if (frame.left.empty() || frame.right.empty()) {
    *msg = "missing image";
    return FrameResult::kRejected;
  }
  if (frame.left.size() != frame.right.size() || frame.left.cols != rig_.left.width ||
      frame.left.rows != rig_.left.height) {
    *msg = "image size " + std::to_string(frame.left.cols) + "x" + std::to_string(frame.left.rows) +
           " / " + std::to_string(frame.right.cols) + "x" + std::to_string(frame.right.rows) +
           " does not match camera_info " + std::to_string(rig_.left.width) + "x" +
           std::to_string(rig_.left.height);
    return FrameResult::kRejected;
  }
  if (!std::isfinite(frame.stamp) || !std::isfinite(lidar_stamp)) {
    *msg = "the frame's stamps are not finite";
    return FrameResult::kRejected;
  }
  if (std::fabs(lidar_stamp - frame.stamp) > settings_.max_sync_skew) {
    *msg = "LiDAR and image stamps differ by " + std::to_string(lidar_stamp - frame.stamp) + " s";
    return FrameResult::kRejected;
  }
  Eigen::Isometry3d T_cl, T_rl;
  std::shared_ptr<const LidarScan> previous;
  double previous_stamp = -1e300, deskew_seconds = 0;
  uint64_t generation = 0;  // a window cleared while the keyframe is built does not get it
  double previous_keyframe_stamp = -1e300;
  // A frame selected by time but then not taken: the next one is judged against the last
  // keyframe taken, not against this one.
  auto rejectAfterSelection = [&](double keyframe_stamp) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (last_keyframe_stamp_ == frame.stamp) last_keyframe_stamp_ = keyframe_stamp;
    return FrameResult::kRejected;
  };
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (frame.stamp < last_stamp_ - settings_.max_time_jump_back) {
      char back[32];
      std::snprintf(back, sizeof back, "%.2f", last_stamp_ - frame.stamp);
      *msg = std::string("time went backwards by ") + back + " s (looping bag?): window cleared";
      if (estimate_)
        *msg += "; the published estimate is kept until a solve from " +
                std::to_string(std::min(estimate_->keyframes_used, settings_.window_size)) +
                " keyframes replaces it";
      window_.clear();
      keyframe_information_.clear();
      previous_scan_.reset();
      last_solve_.reset();  // it described the window just cleared
      ++generation_;
      last_stamp_ = frame.stamp;
      last_keyframe_stamp_ = -1e300;
      new_keyframes_ = 0;
      return FrameResult::kReset;
    }
    last_stamp_ = frame.stamp;
    if (settings_.deskew) {
      previous = previous_scan_;
      previous_stamp = previous_scan_stamp_;
      previous_scan_ = std::make_shared<const LidarScan>(frame.scan);
      previous_scan_stamp_ = frame.stamp;
    }
    if (settings_.tooClose(frame.stamp, last_keyframe_stamp_)) return FrameResult::kTooClose;
    previous_keyframe_stamp = last_keyframe_stamp_;
    last_keyframe_stamp_ = frame.stamp;
    T_cl = estimate_ ? estimate_->T_cam_lidar : rig_.T_cam_lidar;
    T_rl = estimate_ ? estimate_->T_right_left : rig_.T_right_left;
    generation = generation_;
  }
  // De-skewing: the velocity from the previous scan. Without it the keyframe is not taken (a
  // skewed scan would bias the calibration by centimetres at speed); the next frame can be one.
  // A cloud without per-point times is de-skewed only by the azimuth model (ScanSweep::by_azimuth).
  const bool deskew = settings_.deskew && (settings_.sweep.by_azimuth || hasPointTimes(frame.scan));
  auto refuse = [&](const std::string& why) {
    *msg = "keyframe not de-skewed: " + why;
    return rejectAfterSelection(previous_keyframe_stamp);
  };
  const double dt = frame.stamp - previous_stamp;
  if (deskew && !previous) return refuse("no previous scan yet");
  if (deskew && dt > settings_.deskew_max_dt)
    return refuse("the previous scan is " + std::to_string(dt) + " s old (deskew_max_dt " +
                  std::to_string(settings_.deskew_max_dt) + " s)");
  KeyframeSettings ks = settings_.keyframe;
  if (settings_.estimate_stereo) ks.stereo.refinement = settings_.co.stereo_cloud.refinement;
  if (settings_.estimate_stereo && settings_.joint) ks.mesh.sampled_faces = 0;
  std::shared_ptr<Keyframe> kf;
  try {
    // Before the costly part (SGBM, the mesh, de-skewing: 0.3-0.7 s; this takes about 6 ms).
    const std::string quality =
        pairQualityProblem(frame.left, frame.right, settings_.image_quality);
    if (!quality.empty()) {
      *msg = quality;
      return rejectAfterSelection(previous_keyframe_stamp);
    }
    // While the scan is registered to the previous one, the images are matched on another
    // thread: the two take about as long (0.3-0.4 s and 0.2-0.35 s on this 2-core machine). An
    // early return waits for that thread (the future's destructor).
    std::future<Keyframe> images =
        std::async(deskew ? std::launch::async : std::launch::deferred,
                   [&] { return makeImageKeyframe(frame, rig_, T_rl, ks); });
    Frame deskewed;
    const Frame* use = &frame;
    if (deskew) {
      const auto t0 = std::chrono::steady_clock::now();
      const ScanMotion m = estimateScanMotion(*previous, frame.scan, dt);
      if (!m.valid) return refuse(m.message);
      deskewed.stamp = frame.stamp;
      deskewed.scan = frame.scan;
      deskewScan(&deskewed.scan, m, settings_.sweep, lidar_stamp - frame.stamp);
      use = &deskewed;
      deskew_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    kf = std::make_shared<Keyframe>(images.get());
    addScanToKeyframe(kf.get(), *use, rig_, T_cl, ks);
    kf->seconds_deskew = deskew_seconds;
  } catch (const std::exception& e) {  // DataError, or OpenCV's on images it cannot use
    *msg = e.what();
    return rejectAfterSelection(previous_keyframe_stamp);
  }
  if (kf->mesh.faces.size() < 100) {
    // Which of the two it is: a scan without rings, or an initial guess that puts the scan
    // behind or beside the camera (a camera frame that is not the optical one, z forward).
    size_t in_view = 0;
    const CameraIntrinsics& cam = rig_.left;
    for (const auto& p : frame.scan) {
      const Eigen::Vector3d c = T_cl * Eigen::Vector3d(p.x, p.y, p.z);
      if (c.z() < 1.0) continue;
      const double u = cam.fx * c.x() / c.z() + cam.cx, v = cam.fy * c.y() / c.z() + cam.cy;
      in_view += u >= 0 && v >= 0 && u < cam.width && v < cam.height;
    }
    *msg = "LiDAR scan gives only " + std::to_string(kf->mesh.faces.size()) +
           " mesh faces in the cameras' view";
    if (in_view * 50 < frame.scan.size())
      *msg += ": only " + std::to_string(in_view) + " of its " + std::to_string(frame.scan.size()) +
              " points are in the left image under the current T_cam_lidar (the initial one until "
              "an estimate: is the camera frame the optical one, z forward, x right, y down, and "
              "T_cam_lidar camera <- LiDAR?)";
    else
      *msg += " (no ring structure?)";
    return rejectAfterSelection(previous_keyframe_stamp);
  }
  if (static_cast<int>(kf->stereo.points.size()) < settings_.min_stereo_points) {
    *msg = "its stereo cloud has only " + std::to_string(kf->stereo.points.size()) +
           " points (at least " + std::to_string(settings_.min_stereo_points) +
           "): a dark, blurred, differently exposed or mismatched right image?";
    return rejectAfterSelection(previous_keyframe_stamp);
  }
  bool check_rows = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    check_rows = settings_.max_row_offset_px > 0 && !rows_checked_;
    rows_checked_ = true;
  }
  if (check_rows) {
    // On the grey values SGBM matched (Lucas-Kanade assumes equal brightness too).
    cv::Mat left = kf->left_gray.clone(), right = kf->right_gray.clone();
    matchExposure(&left, &right, ks.stereo.equalize_exposure_ratio);
    const VerticalAlignment rows =
        verticalAlignment(left, right, kf->stereo, rig_, kf->T_right_left_used);
    if (rows.points < 100) {  // too little texture to tell: the next keyframe is checked
      std::lock_guard<std::mutex> lock(mutex_);
      rows_checked_ = false;
    } else if (std::fabs(rows.median_px) > settings_.max_row_offset_px) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "the right image's rows lie %+.2f px (median over %d corners; %+.2f px per "
                    "unit of x, %+.2f per unit of y) from where the stereo calibration puts them: "
                    "SGBM matches along rows, so the stereo clouds are biased. Check the cameras' "
                    "camera_info (P, R)%s",
                    rows.median_px, rows.points, rows.slope_x_px, rows.slope_y_px,
                    settings_.estimate_stereo ? "; co-calibration re-rectifies with its estimate"
                                              : " or enable co-calibration");
      *msg = buf;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (generation_ != generation) {
    // Built from the extrinsics (and, de-skewed, the scans) of a window that is gone: a reset
    // would otherwise find a keyframe of the estimate it cleared in its fresh window (session 32
    // review). Its row check, if it had the one, is another keyframe's to do.
    if (check_rows) rows_checked_ = false;
    *msg =
        "the window was cleared while this keyframe was built (reset, or time went backwards): "
        "dropped";
    return FrameResult::kRejected;
  }
  if (built) *built = kf;
  window_.push_back(std::move(kf));
  while (static_cast<int>(window_.size()) > std::max(1, settings_.window_size)) {
    const size_t drop = keyframeToDrop();
    keyframe_information_.erase(window_[drop]->stamp);
    window_.erase(window_.begin() + static_cast<long>(drop));
  }
  ++new_keyframes_;
  return FrameResult::kKeyframe;
}

size_t OnlineCalibrator::keyframeToDrop() const {
  if (settings_.keyframe_selection != "information") return 0;
  // Candidates: every keyframe but the newest that a solve has measured; the newest stays until
  // a solve has seen what it adds.
  std::vector<size_t> measured;
  Matrix6d total = Matrix6d::Zero();
  for (size_t i = 0; i + 1 < window_.size(); ++i) {
    const auto it = keyframe_information_.find(window_[i]->stamp);
    if (it == keyframe_information_.end()) continue;
    measured.push_back(i);
    total += it->second;
  }
  if (measured.size() < 2) return 0;
  // Information in units of the trust limits (0.1 deg, 1 cm), so that rotation and translation
  // compare; the weakest direction is the smallest eigenvalue of what remains after a drop.
  Vector6d scale;
  scale << Vector6d::Constant(0.1 / kDegPerRad).head<3>(), Vector6d::Constant(0.01).tail<3>();
  const Matrix6d S = scale.asDiagonal();
  auto weakest = [&](const Matrix6d& H) {
    return Eigen::SelfAdjointEigenSolver<Matrix6d>(S * H * S).eigenvalues()(0);
  };
  double best = -1;
  std::vector<double> remaining(measured.size());
  for (size_t c = 0; c < measured.size(); ++c) {
    remaining[c] = weakest(total - keyframe_information_.at(window_[measured[c]]->stamp));
    best = std::max(best, remaining[c]);
  }
  // The oldest keyframe whose loss keeps at least 95 % of the best achievable weakest-direction
  // information: recency wins among equals.
  for (size_t c = 0; c < measured.size(); ++c)
    if (remaining[c] >= 0.95 * best) return measured[c];
  return 0;
}

std::vector<double> OnlineCalibrator::windowStamps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<double> stamps;
  for (const auto& k : window_) stamps.push_back(k->stamp);
  return stamps;
}

bool OnlineCalibrator::readyToSolve() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(window_.size()) >= settings_.minKeyframes() && new_keyframes_ > 0;
}

size_t OnlineCalibrator::windowFill() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return window_.size();
}

bool OnlineCalibrator::coCalibrationPending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_.estimate_stereo &&
         static_cast<int>(window_.size()) >= settings_.min_keyframes_co &&
         !(last_solve_ && last_solve_->stereo_estimated);
}

bool OnlineCalibrator::solve(std::string* msg, OnlineEstimate* published, bool recording_ended) {
  std::vector<std::shared_ptr<Keyframe>> snapshot;
  Eigen::Isometry3d T_cl, T_rl;
  std::optional<OnlineEstimate> current;
  std::optional<Matrix6d> sensitivity, new_sensitivity;  // co_sensitivity_ before and after
  bool co = false, keep_clouds = false;
  // The solver itself saw the cancel: coCalibrate, jointCalibrate and solveLidarStereo(Search)
  // all end with the message "cancelled" when the flag is up at their end.
  bool solver_cancelled = false;
  uint64_t generation = 0;
  if (cancel_) {
    *msg = "cancelled";
    return false;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    generation = generation_;
    if (window_.empty() || static_cast<int>(window_.size()) < settings_.minKeyframes()) {
      *msg = "window has " + std::to_string(window_.size()) + " keyframes, needs " +
             std::to_string(settings_.minKeyframes());
      return false;
    }
    // LiDAR first: co-calibration once a LiDAR-stereo estimate is published (or, failing that,
    // once the window is full or no more keyframes will come), so that a start too far off for
    // the alternation gets the LiDAR-stereo solves' wide-basin search first.
    const int fill = static_cast<int>(window_.size());
    co = settings_.estimate_stereo &&
         (!settings_.lidar_first ||
          (fill >= settings_.min_keyframes_co &&
           (estimate_ || fill >= settings_.window_size || recording_ended)));
    // Co-calibration recomputes the stereo clouds in place: it gets deep copies. The LiDAR-stereo
    // solve only reads, and the shared keyframes are never modified after insertion.
    for (const auto& k : window_) snapshot.push_back(co ? std::make_shared<Keyframe>(*k) : k);
    new_keyframes_ = 0;
    current = estimate_;
    sensitivity = co_sensitivity_;
    T_cl = current ? current->T_cam_lidar : rig_.T_cam_lidar;
    T_rl = current ? current->T_right_left : rig_.T_right_left;
  }
  const auto t0 = std::chrono::steady_clock::now();
  OnlineEstimate e;
  std::vector<Matrix6d> keyframe_info;
  std::vector<Keyframe*> win;
  for (auto& k : snapshot) win.push_back(k.get());
  // A solver that throws (a DataError on an estimate gone far off, OpenCV on data it cannot use)
  // fails this solve, not the node: the published estimate stays.
  try {
    if (co) {
      CoCalibrationSettings cs = settings_.co;
      cs.lidar.cancel = &cancel_;
      // Its LiDAR-first fallback searches as the LiDAR-stereo solves below do.
      if (current || static_cast<int>(win.size()) <
                         std::min(settings_.window_size, settings_.search_min_keyframes))
        cs.lidar.search_step_deg = 0;
      // The pair from feature matches only for a start without an estimate: from a LiDAR-first one
      // round 1's photometric solve has good depth, and its yaw is far tighter than the matches'
      // (generated windows: 0.03-0.07 deg off; real KITTI 0.13-0.15 deg).
      if (current) cs.stereo_from_features = false;
      // Warm only from a co-calibration: a LiDAR-first estimate has the stereo pair at its start.
      const bool from_co = current && current->stereo_estimated && settings_.warm_start_fine_only;
      // The joint solve has no warm rounds: it starts from the estimate (see OnlineSettings), and
      // its initial round's LiDAR-stereo solve runs the fine stage alone, as a warm LiDAR-stereo
      // update does.
      if (settings_.joint && from_co) cs.lidar.run_coarse = false;
      const bool warm = from_co && !settings_.joint;
      if (warm) {
        cs.warm_first_round = true;
        cs.max_rounds = std::min(cs.max_rounds, settings_.warm_co_rounds);
        // Its LiDAR covariance must hold the pair's uncertainty as the published one does.
        if (sensitivity) {
          cs.reuse_lidar_sensitivity = true;
          cs.lidar_sensitivity_to_stereo = *sensitivity;
        }
      }
      CoCalibrationResult r;
      if (settings_.joint) {
        JointCalibrationSettings js;
        js.co = cs;
        r = jointCalibrate(win, rig_, T_cl, T_rl, js);
      } else {
        r = coCalibrate(win, rig_, T_cl, T_rl, cs);
      }
      solver_cancelled = r.message == "cancelled";
      if (!warm && r.stable && !r.lidar_stereo_sensitivity.isZero())
        new_sensitivity = r.lidar_stereo_sensitivity;
      keep_clouds = true;  // swapped into the window if the estimate is published (below)
      keyframe_info = r.lidar.keyframe_information;
      e.T_cam_lidar = r.lidar.T_cam_lidar;
      e.T_right_left = r.stereo.T_right_left;
      e.cov_lidar = r.lidar.covariance;
      e.cov_lidar_known = r.lidar.covariance_known;
      e.cov_stereo_known = r.stereo.covariance_known;
      e.cov_lidar_given_stereo = r.lidar_covariance_given_stereo;
      e.cov_stereo = r.stereo.covariance;
      std::copy(r.lidar.observable, r.lidar.observable + 6, e.observable_lidar);
      e.weakest_lidar = r.lidar.weakest();
      e.weakest_stereo = r.stereo.weakest();
      std::copy(r.stereo.observable, r.stereo.observable + 6, e.observable_stereo);
      e.converged = warm ? r.lidar.converged && r.stereo.converged : r.converged;
      e.cost_lidar = r.lidar.final_cost, e.cost_stereo = r.stereo.final_cost;
      e.iterations_lidar = r.lidar.iterations, e.iterations_stereo = r.stereo.iterations;
      e.co_rounds = r.rounds;
      e.stereo_estimated = true;
      if (!warm)
        *msg = r.message;
      else if (!r.stereo.converged)
        *msg = "left-right: " + r.stereo.message;
      else if (!r.lidar.converged)
        *msg = "LiDAR-stereo: " + r.lidar.message;
      else
        msg->clear();
    } else {
      std::vector<const Keyframe*> cwin(win.begin(), win.end());
      LidarStereoSettings ls = settings_.co.lidar;
      ls.cancel = &cancel_;
      ls.disparity_sigma = settings_.keyframe.stereo.disparity_sigma;
      if (current && settings_.warm_start_fine_only) ls.run_coarse = false;
      if (current || static_cast<int>(cwin.size()) <
                         std::min(settings_.window_size, settings_.search_min_keyframes))
        ls.search_step_deg = 0;
      const LidarStereoResult r = solveLidarStereoSearch(cwin, T_cl, ls);
      solver_cancelled = r.message == "cancelled";
      keyframe_info = r.keyframe_information;
      e.T_cam_lidar = r.T_cam_lidar;
      e.T_right_left = T_rl;
      e.cov_lidar = e.cov_lidar_given_stereo = r.covariance;
      e.cov_lidar_known = r.covariance_known;
      e.cov_stereo = Matrix6d::Zero();
      std::copy(r.observable, r.observable + 6, e.observable_lidar);
      e.weakest_lidar = r.weakest();
      std::fill(e.observable_stereo, e.observable_stereo + 6, true);
      if (current && current->stereo_estimated) {  // keep a co-calibrated stereo pair as it is
        e.cov_stereo = current->cov_stereo;
        e.cov_stereo_known = current->cov_stereo_known;
        std::copy(current->observable_stereo, current->observable_stereo + 6, e.observable_stereo);
        e.weakest_stereo = current->weakest_stereo;
        e.stereo_estimated = true;
      }
      e.converged = r.converged;
      e.cost_lidar = r.final_cost;
      e.iterations_lidar = r.iterations;
      *msg = r.message;
    }
  } catch (const std::exception& ex) {
    *msg = std::string("the solve failed: ") + ex.what() +
           (current ? " (keeping the previous estimate)" : " (nothing published yet)");
    return false;
  }
  e.keyframes_used = static_cast<int>(snapshot.size());
  e.stamp = snapshot.back()->stamp;
  e.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(mutex_);
  if (cancel_) {
    // The solvers poll the flag; a cancel that came after their last poll lets the solve end.
    *msg = solver_cancelled ? "cancelled" : "cancelled after the solve had ended";
    return false;
  }
  if (generation_ != generation) {
    *msg =
        "the window was cleared during the solve (reset, or time went backwards): its result "
        "was discarded";
    return false;
  }
  if (keyframe_info.size() == snapshot.size())
    for (size_t i = 0; i < snapshot.size(); ++i)
      for (const auto& k : window_)  // only keyframes still in the window (it slides meanwhile)
        if (k->stamp == snapshot[i]->stamp) keyframe_information_[k->stamp] = keyframe_info[i];
  e.solve_id = ++solves_kept_;
  if (e.converged && estimate_)  // NaN when the summed covariance is not positive definite
    e.chi2_to_published =
        nees(poseError(e.T_cam_lidar, estimate_->T_cam_lidar), e.cov_lidar + estimate_->cov_lidar);
  auto notPublished = [&](std::string why) {
    // A converged solve kept back: does it still agree with what is published?
    if (std::isfinite(e.chi2_to_published)) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "; it is %.1f chi2 (6 DoF) from the published one",
                    e.chi2_to_published);
      why += buf;
      if (e.chi2_to_published > settings_.changed_chi2)
        why +=
            ", more than the two covariances allow: the extrinsic may have changed since it was "
            "published (~reset recalibrates)";
    }
    *msg = why;
    last_solve_ = e;
    last_solve_->message = why;
    return false;
  };
  if (!e.converged)
    return notPublished("not converged (" + *msg + "): " +
                        (estimate_ ? "keeping the previous estimate" : "nothing published yet"));
  // A covariance with NaN would pass every later "less certain" comparison (NaN compares false):
  // not published, the first estimate included.
  if ((e.cov_lidar_known && !e.cov_lidar.allFinite()) ||
      (e.stereo_estimated && e.cov_stereo_known && !e.cov_stereo.allFinite()))
    return notPublished("its covariance is not finite: " + std::string(estimate_
                                                                           ? "keeping the previous "
                                                                             "estimate"
                                                                           : "nothing published "
                                                                             "yet"));
  if (estimate_) {
    // After the window restarted (a reset of the window by a bag's loop; the estimate is kept),
    // its first solves come from a few keyframes, and their covariances hardly show it (the
    // model error's floor dominates them): wait until the window holds as many as the estimate
    // it would replace (session 22 audit: 3 keyframes replaced 10, rotation errors 2-3x larger).
    if (e.keyframes_used < std::min(estimate_->keyframes_used, settings_.window_size))
      return notPublished("from " + std::to_string(e.keyframes_used) +
                          " keyframes, fewer than the published estimate's " +
                          std::to_string(estimate_->keyframes_used) +
                          ": kept it until the window refills");
    // Like with like: the stereo part counts only when both estimated it. Axis by axis. The
    // first co-calibrated estimate after LiDAR-first ones has its own, looser bound: their LiDAR
    // covariance takes camera_info's stereo pair as exact, the co-calibrated one does not (its
    // clouds' scale and yaw are free), so it is wider by construction (session 23: with
    // max_variance_growth, tescalib_calibrate --mode co never published a co-calibrated one on
    // generated urban drives; rz variance 2.4-3.3x). And since session 29 the co-calibrated LiDAR
    // covariance carries the pair's uncertainty too, which the LiDAR-first one cannot: the first
    // co-calibrated one is compared by its LiDAR covariance given the pair (online_e2e_co: rz
    // sigma 0.046 deg with the pair's uncertainty vs 0.013 deg LiDAR-first, never published).
    const bool both = e.stereo_estimated && estimate_->stereo_estimated;
    const bool first_co = e.stereo_estimated && !estimate_->stereo_estimated;
    const double growth =
        first_co ? settings_.max_variance_growth_first_co : settings_.max_variance_growth;
    static const char* kAxes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
    for (int part = 0; part < (both ? 2 : 1); ++part) {
      const Matrix6d& now = part == 1  ? e.cov_stereo
                            : first_co ? e.cov_lidar_given_stereo
                                       : e.cov_lidar;
      const Matrix6d& before = part == 0 ? estimate_->cov_lidar : estimate_->cov_stereo;
      for (int i = 0; i < 6; ++i)
        if (!std::isfinite(now(i, i)) || now(i, i) > growth * before(i, i)) {
          char buf[240];
          std::snprintf(buf, sizeof buf,
                        "new estimate is less certain than the published one (%s sigma of %s "
                        "%.3g vs %.3g, from %d vs %d keyframes): kept the old one",
                        part == 1  ? "stereo"
                        : first_co ? "LiDAR (given the pair)"
                                   : "LiDAR",
                        kAxes[i], std::sqrt(now(i, i)), std::sqrt(before(i, i)), e.keyframes_used,
                        estimate_->keyframes_used);
          return notPublished(buf);
        }
    }
  }
  estimate_ = last_solve_ = e;
  if (new_sensitivity) co_sensitivity_ = new_sensitivity;
  // Keep the co-calibration's re-rectified or rescaled clouds: swap those keyframes into the
  // window (its keyframes are shared and never modified in place). Only with the estimate they
  // were rectified for: an unpublished one's would leave the window on a stereo extrinsic
  // nothing else uses (review, session 34), to be re-rectified back by the next solve.
  if (keep_clouds)
    for (const auto& k : snapshot)
      for (auto& w : window_)
        if (w->stamp == k->stamp && !w->T_right_left_used.isApprox(k->T_right_left_used)) w = k;
  if (published) *published = e;
  return true;
}

void OnlineCalibrator::setPreviousScan(std::shared_ptr<const LidarScan> scan, double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  previous_scan_ = std::move(scan);
  previous_scan_stamp_ = stamp;
}

void OnlineCalibrator::noteStamp(double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stamp < last_stamp_ - settings_.max_time_jump_back) ++generation_;
}

void OnlineCalibrator::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  window_.clear();
  keyframe_information_.clear();
  estimate_.reset();
  last_solve_.reset();
  co_sensitivity_.reset();
  rows_checked_ = false;  // a recalibration checks the rows again
  previous_scan_.reset();
  last_stamp_ = -1e300;
  last_keyframe_stamp_ = -1e300;
  new_keyframes_ = 0;
  ++generation_;
}

std::optional<OnlineEstimate> OnlineCalibrator::estimate() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_;
}

std::optional<OnlineEstimate> OnlineCalibrator::lastSolve() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_solve_;
}

Eigen::Isometry3d OnlineCalibrator::currentTcamLidar() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_ ? estimate_->T_cam_lidar : rig_.T_cam_lidar;
}

Eigen::Isometry3d OnlineCalibrator::currentTrightLeft() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return estimate_ ? estimate_->T_right_left : rig_.T_right_left;
}

}  // namespace tescalib
