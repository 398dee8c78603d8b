#include "tescalib/core/online/keyframe_intake.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

#include "tescalib/core/lidar/scan_motion.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

std::string frameProblem(const Frame& frame, double lidar_stamp, const StereoRig& rig,
                         const OnlineSettings& settings) {
  if (frame.scan.empty()) return "empty LiDAR scan";
  if (frame.left.empty() || frame.right.empty()) return "missing image";
  if (frame.left.size() != frame.right.size() || frame.left.cols != rig.left.width ||
      frame.left.rows != rig.left.height)
    return "image size " + std::to_string(frame.left.cols) + "x" + std::to_string(frame.left.rows) +
           " / " + std::to_string(frame.right.cols) + "x" + std::to_string(frame.right.rows) +
           " does not match camera_info " + std::to_string(rig.left.width) + "x" +
           std::to_string(rig.left.height);
  if (!std::isfinite(frame.stamp) || !std::isfinite(lidar_stamp))
    return "the frame's stamps are not finite";
  if (std::fabs(lidar_stamp - frame.stamp) > settings.max_sync_skew)
    return "LiDAR and image stamps differ by " + std::to_string(lidar_stamp - frame.stamp) + " s";
  return "";
}

KeyframeSettings keyframeSettings(const OnlineSettings& settings) {
  KeyframeSettings ks = settings.keyframe;
  if (settings.estimate_stereo) ks.stereo.refinement = settings.co.stereo_cloud.refinement;
  if (settings.estimate_stereo && settings.joint) ks.mesh.sampled_faces = 0;
  return ks;
}

std::shared_ptr<Keyframe> buildKeyframe(const Frame& frame, double lidar_stamp,
                                        const StereoRig& rig, const KeyframeInputs& inputs,
                                        const OnlineSettings& settings, std::string* message) {
  // De-skewing: the velocity from the previous scan. Without it the keyframe is not taken (a
  // skewed scan would bias the calibration by centimetres at speed); the next frame can be one.
  // A cloud without per-point times is de-skewed only by the azimuth model (ScanSweep::by_azimuth).
  const bool deskew = settings.deskew && (settings.sweep.by_azimuth || hasPointTimes(frame.scan));
  auto refuse = [&](const std::string& why) -> std::shared_ptr<Keyframe> {
    *message = "keyframe not de-skewed: " + why;
    return nullptr;
  };
  const double dt = frame.stamp - inputs.previous_scan_stamp;
  if (deskew && !inputs.previous_scan) return refuse("no previous scan yet");
  if (deskew && dt > settings.deskew_max_dt)
    return refuse("the previous scan is " + std::to_string(dt) + " s old (deskew_max_dt " +
                  std::to_string(settings.deskew_max_dt) + " s)");
  const KeyframeSettings ks = keyframeSettings(settings);
  try {
    // Before the costly part (SGBM, the mesh, de-skewing: 0.3-0.7 s; this takes about 6 ms).
    const std::string quality = pairQualityProblem(frame.left, frame.right, settings.image_quality);
    if (!quality.empty()) {
      *message = quality;
      return nullptr;
    }
    // While the scan is registered to the previous one, the images are matched on another
    // thread: the two take about as long (0.3-0.4 s and 0.2-0.35 s on this 2-core machine). An
    // early return waits for that thread (the future's destructor).
    std::future<Keyframe> images =
        std::async(deskew ? std::launch::async : std::launch::deferred,
                   [&] { return makeImageKeyframe(frame, rig, inputs.T_right_left, ks); });
    Frame deskewed;
    const Frame* use = &frame;
    double deskew_seconds = 0;
    if (deskew) {
      const auto t0 = std::chrono::steady_clock::now();
      const ScanMotion m = estimateScanMotion(*inputs.previous_scan, frame.scan, dt);
      if (!m.valid) return refuse(m.message);
      deskewed.stamp = frame.stamp;
      deskewed.scan = frame.scan;
      deskewScan(&deskewed.scan, m, settings.sweep, lidar_stamp - frame.stamp);
      use = &deskewed;
      deskew_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    auto kf = std::make_shared<Keyframe>(images.get());
    addScanToKeyframe(kf.get(), *use, rig, inputs.T_cam_lidar, ks);
    kf->seconds_deskew = deskew_seconds;
    return kf;
  } catch (const std::exception& e) {  // DataError, or OpenCV's on images it cannot use
    *message = e.what();
    return nullptr;
  }
}

std::string keyframeProblem(const Keyframe& keyframe, const LidarScan& scan,
                            const Eigen::Isometry3d& T_cam_lidar, const StereoRig& rig,
                            const OnlineSettings& settings) {
  if (keyframe.mesh.faces.size() < 100) {
    // Which of the two it is: a scan without rings, or an initial guess that puts the scan
    // behind or beside the camera (a camera frame that is not the optical one, z forward).
    size_t in_view = 0;
    const CameraIntrinsics& cam = rig.left;
    for (const auto& p : scan) {
      const Eigen::Vector3d c = T_cam_lidar * Eigen::Vector3d(p.x, p.y, p.z);
      if (c.z() < 1.0) continue;
      const Eigen::Vector2d px = cam.project(c);
      const double u = px.x(), v = px.y();
      in_view += u >= 0 && v >= 0 && u < cam.width && v < cam.height;
    }
    std::string msg = "LiDAR scan gives only " + std::to_string(keyframe.mesh.faces.size()) +
                      " mesh faces in the cameras' view";
    if (in_view * 50 < scan.size())
      msg += ": only " + std::to_string(in_view) + " of its " + std::to_string(scan.size()) +
             " points are in the left image under the current T_cam_lidar (the initial one until "
             "an estimate: is the camera frame the optical one, z forward, x right, y down, and "
             "T_cam_lidar camera <- LiDAR?)";
    else
      msg += " (no ring structure?)";
    return msg;
  }
  if (static_cast<int>(keyframe.stereo.points.size()) < settings.min_stereo_points)
    return "its stereo cloud has only " + std::to_string(keyframe.stereo.points.size()) +
           " points (at least " + std::to_string(settings.min_stereo_points) +
           "): a dark, blurred, differently exposed or mismatched right image?";
  return "";
}

std::shared_ptr<Keyframe> buildTakenKeyframe(const Frame& frame, double lidar_stamp,
                                             const StereoRig& rig, const KeyframeInputs& inputs,
                                             const OnlineSettings& settings, std::string* message) {
  std::shared_ptr<Keyframe> kf = buildKeyframe(frame, lidar_stamp, rig, inputs, settings, message);
  if (kf) *message = keyframeProblem(*kf, frame.scan, inputs.T_cam_lidar, rig, settings);
  return kf && message->empty() ? kf : nullptr;
}

RowCheck checkRowAlignment(const Keyframe& keyframe, const StereoRig& rig,
                           const OnlineSettings& settings) {
  // On the grey values SGBM matched (Lucas-Kanade assumes equal brightness too).
  cv::Mat left = keyframe.left_gray.clone(), right = keyframe.right_gray.clone();
  matchExposure(&left, &right, keyframeSettings(settings).stereo.equalize_exposure_ratio);
  const VerticalAlignment rows =
      verticalAlignment(left, right, keyframe.stereo, rig, keyframe.T_right_left_used);
  RowCheck check;
  check.rows = rows;
  check.decided = rows.points >= 100;
  if (!check.decided || !(std::fabs(rows.median_px) > settings.max_row_offset_px)) return check;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "the right image's rows lie %+.2f px (median over %d corners; %+.2f px per "
                "unit of x, %+.2f per unit of y) from where the stereo calibration puts them: "
                "SGBM matches along rows, so the stereo clouds are biased. Check the cameras' "
                "camera_info (P, R)%s",
                rows.median_px, rows.points, rows.slope_x_px, rows.slope_y_px,
                settings.estimate_stereo ? "; co-calibration re-rectifies with its estimate"
                                         : " or enable co-calibration");
  check.warning = buf;
  return check;
}

}  // namespace tescalib
