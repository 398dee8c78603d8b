#include "tescalib/core/solvers/keyframe.h"

#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace tescalib {

namespace {
void keepMatches(Keyframe* kf) {
  kf->stereo_matched = kf->stereo;
  kf->stereo_matched.points.clear();
  kf->stereo_matched.points.shrink_to_fit();
  kf->T_right_left_matched = kf->T_right_left_used;
}
}  // namespace

LidarMeshSettings meshSettingsForView(const StereoRig& rig,
                                      const Eigen::Isometry3d& T_cam_lidar_guess,
                                      const KeyframeSettings& s) {
  LidarMeshSettings ms = s.mesh;
  ms.view_axis = T_cam_lidar_guess.linear().transpose() * Eigen::Vector3d::UnitZ();
  const double half_diag = std::atan(
      std::hypot(rig.left.width / 2.0 / rig.left.fx, rig.left.height / 2.0 / rig.left.fy));
  ms.view_half_angle_deg = std::min(89.0, half_diag * 180.0 / M_PI + s.view_margin_deg);
  return ms;
}

Keyframe makeImageKeyframe(const Frame& frame, const StereoRig& rig,
                           const Eigen::Isometry3d& T_right_left, const KeyframeSettings& s) {
  Keyframe kf;
  kf.stamp = frame.stamp;
  cv::cvtColor(frame.left, kf.left_gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(frame.right, kf.right_gray, cv::COLOR_BGR2GRAY);
  kf.stereo = computeStereoCloud(frame.left, frame.right, rig, T_right_left, s.stereo);
  kf.T_right_left_used = T_right_left;
  keepMatches(&kf);
  return kf;
}

void addScanToKeyframe(Keyframe* kf, const Frame& frame, const StereoRig& rig,
                       const Eigen::Isometry3d& T_cam_lidar_guess, const KeyframeSettings& s) {
  kf->stamp = frame.stamp;
  kf->scan = frame.scan;
  const auto t0 = std::chrono::steady_clock::now();
  kf->mesh = buildLidarMesh(frame.scan, meshSettingsForView(rig, T_cam_lidar_guess, s));
  kf->seconds_mesh = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Keyframe makeKeyframe(const Frame& frame, const StereoRig& rig,
                      const Eigen::Isometry3d& T_cam_lidar_guess,
                      const Eigen::Isometry3d& T_right_left, const KeyframeSettings& s) {
  Keyframe kf = makeImageKeyframe(frame, rig, T_right_left, s);
  addScanToKeyframe(&kf, frame, rig, T_cam_lidar_guess, s);
  return kf;
}

void recomputeStereo(Keyframe* kf, const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                     const StereoSettings& settings) {
  cv::Mat l, r;
  cv::cvtColor(kf->left_gray, l, cv::COLOR_GRAY2BGR);
  cv::cvtColor(kf->right_gray, r, cv::COLOR_GRAY2BGR);
  kf->stereo = computeStereoCloud(l, r, rig, T_right_left, settings);
  kf->T_right_left_used = T_right_left;
  keepMatches(kf);
}

void retriangulateStereo(Keyframe* kf, const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                         const StereoSettings& settings) {
  if (kf->stereo_matched.disparity.empty()) {
    recomputeStereo(kf, rig, T_right_left, settings);
    return;
  }
  kf->stereo = retriangulateStereoCloud(kf->stereo_matched, rig, T_right_left, settings);
  kf->T_right_left_used = T_right_left;
}

}  // namespace tescalib
