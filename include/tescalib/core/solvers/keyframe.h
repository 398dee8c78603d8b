// A preprocessed keyframe: everything the solvers need from one synchronized frame.
#pragma once

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/lidar/lidar_mesh.h"
#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

struct KeyframeSettings {
  LidarMeshSettings mesh;
  StereoSettings stereo;
  double view_margin_deg = 25.0;  ///< mesh kept within the camera's field of view plus this
};

struct Keyframe {
  double stamp = 0;
  LidarScan scan;      ///< the raw scan (LiDAR frame), kept for overlays
  LidarMesh mesh;      ///< LiDAR frame, faces in view of the cameras
  StereoCloud stereo;  ///< left camera frame, computed with `T_right_left_used`
  Eigen::Isometry3d T_right_left_used = Eigen::Isometry3d::Identity();
  /// SGBM's disparity (and its rectification, no points) that `stereo` was triangulated from,
  /// matched with `T_right_left_matched`: small changes re-triangulate it instead of matching
  /// again.
  StereoCloud stereo_matched;
  Eigen::Isometry3d T_right_left_matched = Eigen::Isometry3d::Identity();
  cv::Mat left_gray, right_gray;  ///< CV_8U, as delivered (the photometric solver rectifies)
  double seconds_mesh = 0;
  double seconds_deskew = 0;  ///< motion estimate + de-skewing of the scan (0: not de-skewed)
};

/// Mesh settings restricted to what the left camera can see under `T_cam_lidar_guess`: its optical
/// axis in the LiDAR frame and half its diagonal field of view plus `settings.view_margin_deg`.
LidarMeshSettings meshSettingsForView(const StereoRig& rig,
                                      const Eigen::Isometry3d& T_cam_lidar_guess,
                                      const KeyframeSettings& settings);

/// Preprocesses one frame: LiDAR mesh (restricted to what the cameras can see under the initial
/// `T_cam_lidar` guess plus a margin) and the stereo cloud with `T_right_left`.
Keyframe makeKeyframe(const Frame& frame, const StereoRig& rig,
                      const Eigen::Isometry3d& T_cam_lidar_guess,
                      const Eigen::Isometry3d& T_right_left, const KeyframeSettings& settings = {});

/// makeKeyframe in two halves, so that the online calibrator can match the images while it
/// registers the scan for de-skewing: the images' half (grey images, stereo cloud; no mesh) ...
Keyframe makeImageKeyframe(const Frame& frame, const StereoRig& rig,
                           const Eigen::Isometry3d& T_right_left,
                           const KeyframeSettings& settings = {});
/// ... and the scan's (stamp, scan, mesh) into it.
void addScanToKeyframe(Keyframe* kf, const Frame& frame, const StereoRig& rig,
                       const Eigen::Isometry3d& T_cam_lidar_guess,
                       const KeyframeSettings& settings = {});

/// Recomputes only the stereo cloud of a keyframe with a new left->right estimate (SGBM again).
void recomputeStereo(Keyframe* kf, const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                     const StereoSettings& settings);

/// The stereo cloud of the keyframe's last SGBM matches triangulated with a new left->right
/// estimate (retriangulateStereoCloud): for small changes, about 10x cheaper than matching again.
void retriangulateStereo(Keyframe* kf, const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                         const StereoSettings& settings);

}  // namespace tescalib
